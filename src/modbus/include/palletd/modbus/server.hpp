// palletd modbus: the Modbus TCP server for the PLC (interface version 1, docs/register-map.md).
//
// One poll() loop thread owns the sockets, the libmodbus context and register mapping, and the
// Handshake. Requests are framed here on non-blocking sockets (a client that sends half a frame
// never blocks the others), validated here, and only valid requests reach modbus_reply (whose
// exception paths sleep and flush); errors are answered with modbus_reply_exception.
//
// Thread safety: start()/stop()/the destructor belong to one owner thread. publish_result(),
// publish_status(), wait_event(), registers(), stats(), port() and last_alive() may be called
// from any thread at any time. Published records are immutable and taken over by the server
// thread between two requests, so a reader never sees a half-written result.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "palletd/core/expected.hpp"
#include "palletd/modbus/handshake.hpp"
#include "palletd/modbus/register_map.hpp"

namespace palletd::modbus {

struct ServerOptions {
  std::string bind_address = "127.0.0.1";  ///< numeric IPv4/IPv6 or a host name; "::" = dual stack
  std::uint16_t port = 502;                ///< 0 = any free port (see ModbusServer::port())
  std::uint8_t unit_id = 1;                ///< answer this unit id only (others: exception 0B); 0 = any
  std::vector<std::string> allow;          ///< addresses/CIDR allowed to connect; empty = any
  std::vector<std::string> read_only;      ///< addresses/CIDR whose writes get exception 02
  int max_connections = 16;                ///< more: the longest-idle connection is closed
  double idle_timeout_s = 60.0;            ///< close connections idle this long [s]; 0 = never
  HandshakeOptions handshake;
  std::size_t max_queued_events = 64;      ///< oldest events are dropped beyond this
  /// Optional log sink, called from the server thread (connections, refusals, send errors).
  std::function<void(const std::string&)> log;
};

struct ServerStats {
  std::uint64_t connections_accepted = 0;
  std::uint64_t connections_refused = 0;  ///< not on the allow list
  std::uint64_t connections_evicted = 0;  ///< closed for a newer one at the connection cap
  std::uint64_t connections_idle_closed = 0;
  std::uint64_t requests = 0;             ///< complete frames handled (answered or dropped)
  std::uint64_t exceptions = 0;           ///< exception responses sent
  std::array<std::uint64_t, 16> exceptions_by_code{};  ///< exception responses per code (01..0B)
  std::uint64_t missed_triggers = 0;      ///< triggers refused while Busy or not Ready (not saturated)
  bool plc_heartbeat_lost = false;        ///< the PLC heartbeat watch has fired (error 6)
  std::uint64_t frames_dropped = 0;       ///< protocol id != 0
  std::uint64_t events_dropped = 0;       ///< queue overflow
  std::size_t open_connections = 0;
};

class ModbusServer {
 public:
  explicit ModbusServer(ServerOptions options);
  ~ModbusServer();  ///< stop()s
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;
  ModbusServer(ModbusServer&&) = delete;
  ModbusServer& operator=(ModbusServer&&) = delete;

  /// Parses the address lists, binds and listens (so the port is taken when this returns ok),
  /// then starts the poll thread. Fails on a bad option or a port in use. Call it once: a
  /// stopped server is not restarted (make a new one).
  Status start();
  /// Closes every connection and joins the thread. Idempotent; wakes wait_event().
  void stop();

  /// The bound port (meaningful after a successful start()).
  [[nodiscard]] std::uint16_t port() const;

  /// A finished detection for the PLC. Every published result is shown in order.
  void publish_result(std::shared_ptr<const ResultRecord> result);
  /// The service's live state; the newest one wins.
  void publish_status(std::shared_ptr<const ServiceStatus> status);

  /// The next trigger / snapshot request, or nothing after `timeout` or once stopped.
  std::optional<HandshakeEvent> wait_event(std::chrono::milliseconds timeout);

  /// A copy of the register image as the PLC reads it (as of the end of the last loop pass).
  [[nodiscard]] RegisterImage registers() const;
  /// Counters as of the end of the last loop pass (they lag an event by up to one pass).
  [[nodiscard]] ServerStats stats() const;
  /// When the poll loop last ran (it wakes at least every 200 ms); for the watchdog.
  [[nodiscard]] std::chrono::steady_clock::time_point last_alive() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palletd::modbus
