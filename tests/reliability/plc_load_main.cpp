// palletd_plc_load: drives a running palletd over Modbus TCP like a PLC (trigger handshake every
// --period-ms) with --pollers extra clients reading the status and result blocks at --poll-hz and
// --flooders clients opening connections that carry one malformed or illegal request each.
// Prints one line per --window-s and a summary; exit 0 when every handshake completed and no
// poll went unanswered, 1 otherwise. Used by scripts/soak.sh and tests/bench/load_bench.sh.
#include <cstdio>
#include <iostream>

#include <CLI/CLI.hpp>

#include "plc_load.hpp"

int main(int argc, char** argv) {
  CLI::App app{"palletd_plc_load: PLC handshakes plus pollers against a running palletd", "palletd_plc_load"};
  palletd::test::LoadOptions o;
  app.add_option("--host", o.host)->capture_default_str();
  app.add_option("--port", o.port)->required();
  app.add_option("--unit", o.unit_id)->capture_default_str();
  app.add_option("--recipe", o.recipe)->capture_default_str();
  app.add_option("--period-ms", o.trigger_period_ms, "trigger period; 0 = pollers only")->capture_default_str();
  app.add_option("--triggers", o.triggers, "stop after this many handshakes (0 = run for --duration-s)");
  app.add_option("--pollers", o.pollers, "clients polling status + result blocks")->capture_default_str();
  app.add_option("--poll-hz", o.poll_hz)->capture_default_str();
  app.add_option("--flooders", o.flooders, "clients opening connections with one bad request each")
      ->capture_default_str();
  app.add_option("--flood-hz", o.flood_hz, "connections per second per flooder")->capture_default_str();
  app.add_option("--duration-s", o.duration_s)->capture_default_str();
  app.add_option("--window-s", o.window_s, "print a line every this many seconds")->capture_default_str();
  app.add_option("--timeout-ms", o.handshake_timeout_ms)->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  const auto report = palletd::test::run_load(o, nullptr, [](const palletd::test::LoadReport& r,
                                                             const palletd::test::LatencySummary& w) {
    std::printf("window t=%.1f s handshakes=%zu p50=%.1f ms p99=%.1f ms max=%.1f ms total_ok=%llu failed=%llu\n",
                r.elapsed_s, w.count, w.p50_ms, w.p99_ms, w.max_ms,
                static_cast<unsigned long long>(r.handshakes_ok), static_cast<unsigned long long>(r.handshakes_failed));
    std::fflush(stdout);
  });
  const auto s = palletd::test::summarize(report.latencies_ms);
  std::printf(
      "total elapsed=%.1f s handshakes_ok=%llu handshakes_failed=%llu results_failed=%llu "
      "p50=%.1f ms p99=%.1f ms max=%.1f ms poll_cycles=%llu poll_rate=%.1f Hz poll_errors=%llu "
      "poll_connect_errors=%llu torn_reads=%llu flood_connections=%llu flood_exceptions=%llu "
      "flood_connect_errors=%llu\n",
      report.elapsed_s, static_cast<unsigned long long>(report.handshakes_ok),
      static_cast<unsigned long long>(report.handshakes_failed),
      static_cast<unsigned long long>(report.results_failed), s.p50_ms, s.p99_ms, s.max_ms,
      static_cast<unsigned long long>(report.poll_cycles),
      o.pollers > 0 ? static_cast<double>(report.poll_cycles) / report.elapsed_s / o.pollers : 0.0,
      static_cast<unsigned long long>(report.poll_errors),
      static_cast<unsigned long long>(report.poll_connect_errors),
      static_cast<unsigned long long>(report.torn_reads),
      static_cast<unsigned long long>(report.flood_connections),
      static_cast<unsigned long long>(report.flood_exceptions),
      static_cast<unsigned long long>(report.flood_connect_errors));
  for (const auto& e : report.errors) std::fprintf(stderr, "error: %s\n", e.c_str());
  const bool clean = report.handshakes_failed == 0 && report.poll_errors == 0 && report.poll_connect_errors == 0;
  return clean ? 0 : 1;
}
