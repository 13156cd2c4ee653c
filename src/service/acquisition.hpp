// The acquisition thread: owns the camera, answers "a frame captured after time T" requests.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "palletd/drivers/camera.hpp"
#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"

namespace palletd {

/// Runs one thread that owns a CameraSupervisor.
///
/// A request names the trigger time T. Cameras in trigger mode are triggered after T, so their
/// next frame is exposed after T. Free-running cameras keep streaming; a frame that completed
/// after T may still have started its exposure before T, so the request is answered with the
/// second frame completed after T (the first one is dropped and counted).
class Acquisition {
 public:
  using Clock = std::chrono::steady_clock;
  /// Called from the acquisition thread about every 100 ms and after every grab.
  using StatusCallback = std::function<void(const CameraSupervisor&)>;

  Acquisition(std::unique_ptr<CameraSupervisor> camera, StatusCallback on_status);
  ~Acquisition();  ///< stop()s
  Acquisition(const Acquisition&) = delete;
  Acquisition& operator=(const Acquisition&) = delete;
  Acquisition(Acquisition&&) = delete;
  Acquisition& operator=(Acquisition&&) = delete;

  void start();
  void stop();

  /// Blocks the caller (the pipeline) until a frame captured after `trigger_time` arrives, the
  /// timeout passes, or the thread stops.
  Expected<Frame> frame_after(Clock::time_point trigger_time, std::chrono::milliseconds timeout);

  [[nodiscard]] Clock::time_point last_alive() const { return Clock::time_point(Clock::duration(alive_.load())); }
  [[nodiscard]] const CameraSupervisor& camera() const { return *camera_; }
  [[nodiscard]] std::uint64_t stale_frames_dropped() const { return stale_dropped_.load(); }
  /// Times a trigger-mode camera was restarted (stop, close, open, start) because its grabs
  /// timed out for kRestartAfterFailures triggers in a row while it claimed to be streaming.
  [[nodiscard]] std::uint64_t camera_restarts() const { return restarts_.load(); }
  static constexpr int kRestartAfterFailures = 3;

 private:
  struct Request {
    std::uint64_t id = 0;
    Clock::time_point trigger_time;
    Clock::time_point deadline;
    std::optional<Expected<Frame>> answer;
  };
  void run();
  Expected<Frame> acquire(const Request& request);
  void mark_alive() { alive_.store(Clock::now().time_since_epoch().count()); }

  std::unique_ptr<CameraSupervisor> camera_;
  StatusCallback on_status_;
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<Clock::duration::rep> alive_{0};
  std::atomic<std::uint64_t> stale_dropped_{0};
  std::atomic<std::uint64_t> restarts_{0};
  int failed_in_row_ = 0;  ///< acquisition thread only

  std::mutex mutex_;
  std::condition_variable cv_;
  Request* pending_ = nullptr;  ///< guarded by mutex_; owned by the waiting caller
  std::uint64_t next_id_ = 1;   ///< guarded by mutex_
};

}  // namespace palletd
