// Load generator for the reliability tests, the load benchmark and scripts/soak.sh: one PLC doing
// the full trigger handshake at a fixed period, plus N pollers reading the status and result
// blocks at a fixed rate, all over Modbus TCP (libmodbus through PlcClient), and M flooders
// opening connections that each carry one malformed or illegal request (hand-made frames).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace palletd::test {

struct LoadOptions {
  std::string host = "127.0.0.1";
  int port = 1502;
  int unit_id = 1;
  std::uint16_t recipe = 6;
  double trigger_period_ms = 200.0;  ///< start of one handshake to the next; 0 = no PLC
  int triggers = 0;                  ///< stop after this many handshakes (0 = until duration)
  int pollers = 0;                   ///< extra clients reading status + result blocks
  double poll_hz = 100.0;            ///< poll cycles per second per poller
  /// Extra clients that connect, send one malformed or illegal request, read the answer and
  /// close, again and again (a connection flood of bad requests).
  int flooders = 0;
  double flood_hz = 50.0;            ///< connections per second per flooder
  double duration_s = 10.0;          ///< upper bound on the run [s]
  double handshake_timeout_ms = 10000.0;
  double window_s = 0.0;             ///< call on_window every window_s seconds (0 = never)
};

/// Latency summary over one window or a whole run.
struct LatencySummary {
  std::size_t count = 0;
  double p50_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
};
LatencySummary summarize(std::vector<double> latencies_ms);

struct LoadReport {
  std::uint64_t handshakes_ok = 0;
  std::uint64_t handshakes_failed = 0;   ///< timed out or a Modbus error
  std::uint64_t results_failed = 0;      ///< handshakes whose result status was "failed"
  std::uint64_t poll_cycles = 0;         ///< status + result block reads completed
  std::uint64_t poll_errors = 0;         ///< requests unanswered (timeout) or answered with an error
  std::uint64_t poll_connect_errors = 0;
  std::uint64_t torn_reads = 0;          ///< result id in 200 and 530 differed (pollers read unguarded)
  std::uint64_t flood_connections = 0;   ///< connections the flooders opened
  std::uint64_t flood_exceptions = 0;    ///< their requests answered with a Modbus exception
  std::uint64_t flood_connect_errors = 0;
  double elapsed_s = 0.0;
  std::vector<double> latencies_ms;      ///< trigger written -> ResultReady seen, per handshake
  std::vector<std::string> errors;       ///< the first few error messages
};

/// Runs until `triggers` handshakes are done, duration_s passes or `stop` becomes true.
/// on_window(report so far, latencies of the window) is called from the PLC thread.
LoadReport run_load(const LoadOptions& options, const std::atomic<bool>* stop = nullptr,
                    const std::function<void(const LoadReport&, const LatencySummary&)>& on_window = {});

}  // namespace palletd::test
