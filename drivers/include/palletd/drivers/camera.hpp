// palletd drivers: one small camera interface, the factory that builds the configured driver,
// and the supervisor that keeps a camera streaming (reconnect with backoff).
//
// Nothing here exposes vendor types: the Aravis and OpenNI2 headers stay inside drivers/.
//
// State machine of a Camera (every transition not listed is refused with an error):
//
//     closed --open()--> open --start()--> streaming
//       ^                 ^  <--stop()---     |
//       |                 |                   | grab() finds the camera gone (unplugged,
//       +----close()------+---close()---------+ powered off, stream stopped, folder removed)
//       |                                     v
//       +-------------close()------------- faulted --open()--> open
//
// - Constructors do no I/O; open() connects and reads the camera's identity.
// - grab() only in `streaming`. A grab that fails because of one bad frame (a timeout, an
//   incomplete frame, a corrupt file) returns the error and leaves the state alone; a grab that
//   finds the camera gone moves it to `faulted`. From `faulted` the owner calls close() and
//   open() again (CameraSupervisor does this with backoff).
// - state() and counters() may be read from any thread; everything else belongs to one thread
//   (the acquisition thread).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"

namespace palletd {

struct CameraConfig;

enum class CameraState { kClosed, kOpen, kStreaming, kFaulted };

/// "closed" | "open" | "streaming" | "faulted".
const char* to_string(CameraState state);

/// Who the camera is; filled from the configuration before open(), from the device after it.
struct CameraIdentity {
  std::string driver;   ///< "replay" | "aravis" | "openni2"
  std::string vendor;
  std::string model;
  std::string serial;
  std::string address;  ///< IP address, device URI, .oni path or replay folder

  /// "model-serial", the Frame::camera_id of this camera's frames.
  [[nodiscard]] std::string id() const;
};

/// Monotonic counters since the camera object was made (they survive reconnects).
struct CameraCounters {
  std::uint64_t frames = 0;      ///< frames returned by grab()
  std::uint64_t drops = 0;       ///< frames the camera sent that were lost (no buffer, overrun)
  std::uint64_t incomplete = 0;  ///< frames with missing packets / failed reads
  std::uint64_t resent = 0;      ///< packets the camera resent on request
  std::uint64_t timeouts = 0;    ///< grabs that ended without a frame in time
  std::uint64_t reconnects = 0;  ///< successful re-opens after a fault
  std::uint64_t faults = 0;      ///< times the camera went to `faulted`
};

/// A depth camera. Non-copyable, non-movable (drivers hold callbacks into themselves).
class Camera {
 public:
  virtual ~Camera() = default;
  Camera(const Camera&) = delete;
  Camera& operator=(const Camera&) = delete;
  Camera(Camera&&) = delete;
  Camera& operator=(Camera&&) = delete;

  /// closed|faulted -> open. Connects, configures, reads identity and intrinsics.
  Status open();
  /// open -> streaming.
  Status start();
  /// streaming -> open.
  Status stop();
  /// any -> closed; releases the device. Never fails.
  void close();

  /// streaming only: the next frame, waiting at most `timeout`. In trigger mode the frame of
  /// the last software_trigger(); without a pending trigger this waits for one and times out.
  Expected<Frame> grab(std::chrono::milliseconds timeout);

  /// Whether frames come only on software_trigger() (else the camera free-runs).
  [[nodiscard]] virtual bool trigger_mode() const = 0;
  /// Asks the camera for one frame (trigger mode only; streaming only).
  Status software_trigger();
  /// streaming only: faults the camera when its driver already knows it is gone without asking
  /// it (Aravis: the heartbeat lost the control channel). No I/O; for the idle loop between
  /// triggers, where nothing else would notice.
  void check_alive();

  [[nodiscard]] CameraState state() const { return state_.load(); }
  [[nodiscard]] CameraCounters counters() const;
  /// How long the driver's current call on the camera's control channel (a software trigger, a
  /// probe after a timeout) has been running; zero when none is. Any thread: a camera that does
  /// not answer shows here while the call is still blocked in the vendor library.
  [[nodiscard]] std::chrono::milliseconds control_call_age() const;
  [[nodiscard]] CameraIdentity identity() const;
  /// The message of the last error any call returned ("" when none yet).
  [[nodiscard]] std::string last_error() const;

 protected:
  Camera() = default;

  virtual Status do_open() = 0;
  virtual Status do_start() = 0;
  virtual Status do_stop() = 0;
  virtual void do_close() = 0;
  virtual Expected<Frame> do_grab(std::chrono::milliseconds timeout) = 0;
  virtual Status do_software_trigger();
  /// For drivers: false when the camera is known to be gone (no I/O). Default: true.
  [[nodiscard]] virtual bool do_alive() const { return true; }

  /// For drivers: the camera is gone; the current grab returns an error and the state becomes
  /// `faulted` once do_grab() returns.
  void mark_faulted() { fault_pending_ = true; }
  void set_identity(CameraIdentity identity);
  /// For drivers: a grab ended without a frame in time.
  void count_timeout();

  /// For drivers: brackets a call on the camera's control channel for control_call_age() (RAII;
  /// nested brackets count from the outermost).
  class ControlCall {
   public:
    explicit ControlCall(Camera& camera);
    ~ControlCall();
    ControlCall(const ControlCall&) = delete;
    ControlCall& operator=(const ControlCall&) = delete;
    ControlCall(ControlCall&&) = delete;
    ControlCall& operator=(ControlCall&&) = delete;

   private:
    Camera& camera_;
    bool outermost_;
  };

  // Driver-side counters (frames, reconnects and faults are counted by the base class).
  std::atomic<std::uint64_t> drops_{0};
  std::atomic<std::uint64_t> incomplete_{0};
  std::atomic<std::uint64_t> resent_{0};

 private:
  Status fail(std::string message);

  std::atomic<CameraState> state_{CameraState::kClosed};
  bool fault_pending_ = false;
  bool faulted_since_open_ = false;  ///< the next successful open() counts as a reconnect
  std::atomic<std::uint64_t> frames_{0};
  std::atomic<std::uint64_t> timeouts_{0};
  std::atomic<std::uint64_t> reconnects_{0};
  std::atomic<std::uint64_t> faults_{0};
  std::atomic<std::int64_t> control_call_since_ns_{0};  ///< steady clock [ns]; 0 = no call running
  mutable std::mutex text_mutex_;  ///< guards identity_ and last_error_
  CameraIdentity identity_;
  std::string last_error_;
};

/// Builds the configured driver ("replay" | "aravis" | "openni2"). Does no I/O.
/// Throws std::invalid_argument (start-up only) for an unknown driver name or a configuration
/// that cannot work (e.g. a replay camera without a folder, an unknown pixel format).
std::unique_ptr<Camera> make_camera(const CameraConfig& config);

/// Reconnect delays: `min_s`, doubling on each failure up to `max_s`; reset on success.
class Backoff {
 public:
  Backoff(double min_s, double max_s);
  /// The delay to wait before the next attempt [s]; doubles the one after.
  double next_delay_s();
  void reset() { next_s_ = min_s_; }
  [[nodiscard]] double peek_s() const { return next_s_; }

 private:
  double min_s_;
  double max_s_;
  double next_s_;
};

/// Owns a camera and keeps it streaming for the acquisition thread: opens it on the first
/// grab, and after a fault (or a failed open) closes it and tries again with backoff.
/// grab() never blocks longer than its timeout. camera_ok() / counters() / state() are safe to
/// read from other threads (the status page, the Modbus CameraOK bit).
class CameraSupervisor {
 public:
  /// `control_timeout`: a control-channel call (trigger, probe) running longer than this makes
  /// camera_ok() false at once, before the vendor library gives up on it.
  CameraSupervisor(std::unique_ptr<Camera> camera, double reconnect_min_s, double reconnect_max_s,
                   std::chrono::milliseconds control_timeout = kDefaultControlTimeout);
  static constexpr std::chrono::milliseconds kDefaultControlTimeout{1000};
  ~CameraSupervisor();
  CameraSupervisor(const CameraSupervisor&) = delete;
  CameraSupervisor& operator=(const CameraSupervisor&) = delete;
  CameraSupervisor(CameraSupervisor&&) = delete;
  CameraSupervisor& operator=(CameraSupervisor&&) = delete;

  /// Brings the camera up if due (open + start), then grabs.
  Expected<Frame> grab(std::chrono::milliseconds timeout);
  /// Brings the camera up when it is not streaming and a (re)connect attempt is due; returns
  /// whether it is streaming now. For trigger-mode cameras between triggers, so a camera that
  /// comes back is streaming (CameraOK) before the PLC asks.
  bool ensure_streaming();
  /// Triggers the camera when it is streaming in trigger mode; an error otherwise.
  Status software_trigger();
  /// Stops and closes the camera (no further reconnects until the next grab()).
  void shutdown();

  /// True while the camera is streaming, its last grab or trigger did not fault it, and no
  /// control-channel call has been waiting for the camera longer than the control timeout.
  [[nodiscard]] bool camera_ok() const {
    return camera_->state() == CameraState::kStreaming && camera_->control_call_age() < control_timeout_;
  }
  [[nodiscard]] CameraState state() const { return camera_->state(); }
  [[nodiscard]] CameraCounters counters() const { return camera_->counters(); }
  [[nodiscard]] CameraIdentity identity() const { return camera_->identity(); }
  [[nodiscard]] std::string last_error() const { return camera_->last_error(); }
  [[nodiscard]] bool trigger_mode() const { return camera_->trigger_mode(); }
  /// Seconds until the next reconnect attempt (0 when streaming or due now).
  [[nodiscard]] double seconds_to_retry() const;

 private:
  Status bring_up();

  std::unique_ptr<Camera> camera_;
  Backoff backoff_;
  std::chrono::milliseconds control_timeout_;
  std::chrono::steady_clock::time_point next_attempt_;
  mutable std::mutex retry_mutex_;  ///< guards next_attempt_ for seconds_to_retry()
};

}  // namespace palletd
