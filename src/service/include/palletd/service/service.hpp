// palletd service: the product as a cell runs it. Threads (each catches at its top):
//   acquisition  owns the camera (CameraSupervisor: reconnects with backoff); answers frame
//                requests with a frame captured after the trigger.
//   pipeline     one detection per trigger on one long-lived worker, never two at once;
//                publishes an immutable ResultSnapshot and the PLC's result record.
//   modbus       the ModbusServer's poll loop (register image, handshake).
//   status       the camera's state and counters into the status block every 100 ms (the
//                acquisition thread may be blocked in a camera call meanwhile).
//   main         the caller: signals, sd_notify (the palletd executable, src/palletd/daemon.hpp).
//
// Ownership: Service owns its threads and everything they use. latest() and health() may be
// called from any thread; start/stop/reload from the owner thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "palletd/config/config.hpp"
#include "palletd/core/expected.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/modbus/server.hpp"
#include "palletd/status/snapshot.hpp"

namespace palletd {

class Service {
 public:
  explicit Service(Config config);  ///< no I/O
  ~Service();                       ///< stop()s
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;
  Service(Service&&) = delete;
  Service& operator=(Service&&) = delete;

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

  /// The last result; it is this result's by the time the PLC sees ResultReady rise.
  [[nodiscard]] std::shared_ptr<const ResultSnapshot> latest() const;
  [[nodiscard]] ServiceHealth health() const;
  /// A one-line readable state for sd_notify STATUS= ("ready: 12 triggers, camera ok").
  [[nodiscard]] std::string status_line() const;
  /// The Modbus register image as the PLC reads it.
  [[nodiscard]] modbus::RegisterImage registers() const;
  /// The Modbus server's connection, request and exception counters.
  [[nodiscard]] modbus::ServerStats modbus_stats() const;

  /// Called on the pipeline thread with every result right after it is published (the metrics
  /// count results with it). Set it before start(); it must return within microseconds and not
  /// throw.
  void set_result_listener(std::function<void(const ResultSnapshot&)> listener);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palletd
