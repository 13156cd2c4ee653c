// palletd service: the product as a cell runs it. Threads (each catches at its top):
//   acquisition  owns the camera (CameraSupervisor: reconnects with backoff); answers frame
//                requests with a frame captured after the trigger.
//   pipeline     one detection per trigger on one long-lived worker, never two at once;
//                publishes an immutable ResultSnapshot and the PLC's result record.
//   modbus       the ModbusServer's poll loop (register image, handshake).
//   status       the camera's state and counters into the status block every 100 ms (the
//                acquisition thread may be blocked in a camera call meanwhile).
//   main         the caller: signals, sd_notify (see run_daemon in daemon.hpp).
//
// Ownership: Service owns its threads and everything they use. latest() and health() may be
// called from any thread; start/stop/reload from the owner thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "palletd/config.hpp"
#include "palletd/detection.hpp"
#include "palletd/expected.hpp"
#include "palletd/frame.hpp"
#include "palletd/modbus/register_map.hpp"

namespace palletd {

/// One finished trigger, immutable once published.
struct ResultSnapshot {
  std::uint64_t trigger_seq = 0;
  std::uint16_t request_id = 0;
  std::uint16_t recipe = 0;
  modbus::ErrorCode error = modbus::ErrorCode::kNone;
  std::string error_text;         ///< "" when the detection ran; else why it did not
  Detection detection;
  std::shared_ptr<const Frame> frame;  ///< the frame the result was computed from (may be null)
  double latency_ms = 0.0;        ///< trigger edge to result published [ms]
  std::chrono::system_clock::time_point time;
};

/// Live figures of the service, for the watchdog, sd_notify STATUS= and the status page.
struct ServiceHealth {
  bool threads_alive = false;     ///< every thread looped within the last few seconds
  bool camera_ok = false;
  std::string camera_state;
  std::string camera_id;
  std::uint64_t triggers = 0;
  std::uint64_t results = 0;
  std::uint64_t failures = 0;
  std::uint64_t frames = 0;
  std::uint64_t reconnects = 0;
  std::uint16_t modbus_port = 0;
  std::size_t modbus_connections = 0;
  std::uint64_t camera_restarts = 0;     ///< trigger-mode camera restarted after timeouts in a row
  std::uint64_t incomplete_frames = 0;   ///< frames the driver refused (missing packets, wrong size/format)
  std::uint64_t grab_timeouts = 0;       ///< grabs that ended without a frame in time
  std::uint64_t dropped_frames = 0;      ///< frames the camera sent that were lost (no buffer, overrun)
  std::uint64_t camera_losses = 0;       ///< times the camera was found gone (faulted)
  std::uint64_t resent_packets = 0;      ///< GigE Vision packets resent on request
  std::uint64_t recordings = 0;          ///< frames recorded since start
  std::uint64_t recording_failures = 0;  ///< recordings that failed (disk full, read-only, ...)
  std::string last_recording_error;      ///< "" when the last recording succeeded
};

class Service {
 public:
  explicit Service(Config config);  ///< no I/O
  ~Service();                       ///< stop()s
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  /// Binds the Modbus port, then starts the threads. Fails (with the reason) when the port is
  /// taken or an address list is malformed; nothing keeps running then.
  Status start();
  /// Stops every thread (the current detection finishes first). Idempotent.
  void stop();
  /// Takes recipes, formats, detection parameters and camera_to_base from `config` (the camera
  /// and the Modbus binding stay as started). Applied between two triggers.
  void reload(const Config& config);

  /// Stores the next triggered frame with its result and overlay in the recording folder (the
  /// SaveSnapshot bit's path); an error when recording is not configured.
  Status request_snapshot();

  [[nodiscard]] std::shared_ptr<const ResultSnapshot> latest() const;
  [[nodiscard]] ServiceHealth health() const;
  /// A one-line readable state for sd_notify STATUS= ("ready: 12 triggers, camera ok").
  [[nodiscard]] std::string status_line() const;
  /// The Modbus register image as the PLC reads it.
  [[nodiscard]] modbus::RegisterImage registers() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palletd
