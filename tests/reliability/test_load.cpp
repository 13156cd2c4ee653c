// Load: 32 clients polling the status and result blocks at 100 Hz each, and 4 clients opening
// connections that carry one malformed or illegal request each (20 per second each), while the
// PLC triggers every 200 ms. Every handshake completes and no poll goes unanswered. The
// trigger-to-ResultReady latency is measured idle and under load in the same run and printed; the 1.5x
// comparison is a benchmark (tests/bench/load_bench.sh), not asserted here, because a shared 2-core CI
// machine cannot promise timing. Time bounds are multiplied by PALLETD_TEST_TIME_SCALE (1; 8 in sanitizer
// builds, tests/CMakeLists.txt), the daemon's detection timeout included.
#include <cstdio>

#include "daemon_harness.hpp"
#include "plc_load.hpp"

using namespace palletd::test;

namespace {}  // namespace

TEST_CASE(
    "32 pollers at 100 Hz and floods of bad requests while the PLC triggers every 200 ms: every handshake "
    "completes - no poll unanswered") {
  TempDir dir("load");
  const int port = free_port();
  const auto config = write_config(dir.path, "camera:\n  driver: replay\n  replay:\n    directory: " +
                                                 std::string(PALLETD_TEST_DATA_DIR) +
                                                 "\nmodbus:\n  bind_address: 127.0.0.1\n  port: " + std::to_string(port) +
                                                 "\n  max_connections: 48\npipeline:\n  default_recipe: 6\n"
                                                 "  detection_timeout_ms: " + std::to_string(2000 * kTimeScale) + "\n"
                                                 "logging:\n  level: warn\n");
  NotifySocket notify;
  Daemon daemon({"--config", config.string()}, notify.path, dir.path / "palletd.log");
  REQUIRE(wait_ready(notify, daemon, 10s * kTimeScale));

  LoadOptions idle;
  idle.port = port;
  idle.trigger_period_ms = 200.0;
  idle.triggers = 22;  // each bundled frame once
  idle.duration_s = 60.0 * kTimeScale;
  idle.handshake_timeout_ms = 10000.0 * kTimeScale;
  const LoadReport quiet = run_load(idle);
  INFO("idle errors: " << (quiet.errors.empty() ? "" : quiet.errors.front()));
  CHECK(quiet.handshakes_ok == 22);
  CHECK(quiet.handshakes_failed == 0);

  LoadOptions busy = idle;
  busy.triggers = 44;
  busy.pollers = 32;
  busy.poll_hz = 100.0;
  busy.flooders = 4;
  busy.flood_hz = 20.0;
  const LoadReport loaded = run_load(busy);
  INFO("loaded errors: " << (loaded.errors.empty() ? "" : loaded.errors.front()));
  CHECK(loaded.handshakes_ok == 44);
  CHECK(loaded.handshakes_failed == 0);
  CHECK(loaded.poll_connect_errors == 0);
  CHECK(loaded.poll_errors == 0);  // every poll request was answered in time (2 s)
  CHECK(loaded.poll_cycles > 0);
  // The bad requests reached the server, and it answered those it can answer with an exception
  // (four kinds of six; the other two make it drop the connection).
  INFO("flood connections " << loaded.flood_connections << ", exceptions " << loaded.flood_exceptions);
  CHECK(loaded.flood_connections > 100);
  CHECK(loaded.flood_exceptions * 2 > loaded.flood_connections);
  CHECK(daemon.alive());

  const auto a = summarize(quiet.latencies_ms);
  const auto b = summarize(loaded.latencies_ms);
  const double rate = static_cast<double>(loaded.poll_cycles) / loaded.elapsed_s / busy.pollers;
  std::printf(
      "trigger-to-ResultReady idle: p50 %.1f ms p99 %.1f ms; with 32 pollers and floods: p50 %.1f ms p99 "
      "%.1f ms "
      "(x%.2f); poll rate %.1f Hz per client (4 requests per cycle); %llu bad requests, %llu exceptions\n",
      a.p50_ms, a.p99_ms, b.p50_ms, b.p99_ms, a.p99_ms > 0 ? b.p99_ms / a.p99_ms : 0.0, rate,
      static_cast<unsigned long long>(loaded.flood_connections),
      static_cast<unsigned long long>(loaded.flood_exceptions));
  ::kill(daemon.pid, SIGTERM);
  CHECK(daemon.wait_exit(3s * kTimeScale) == 0);
}
