// Metrics benchmark: the cost of one scrape (Metrics::render() with every family filled the way a
// running cell fills them) and of counting one result (Metrics::observe(), on the pipeline
// thread). Prints a markdown table for docs/benchmarks.md.
//
//   palletd_bench_metrics [--reps N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "palletd/metrics/metrics.hpp"

using namespace palletd;

namespace {

using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

/// A result as a cell produces them: 12 boxes, the five stage timings, sometimes flagged.
ResultSnapshot typical_result(int i) {
  ResultSnapshot r;
  r.detection.status = i % 50 == 0 ? DetectionStatus::kEmpty : DetectionStatus::kOk;
  r.detection.boxes.resize(r.detection.status == DetectionStatus::kOk ? 12 : 0);
  r.detection.timing_ms = {{"total", 18.0 + i % 7}, {"cloud", 2.0},   {"plane", 4.0},
                           {"layer", 3.0},          {"contour", 2.5}, {"layout", 6.0 + i % 5}};
  if (i % 20 == 0) r.detection.ambiguity_kinds = {AmbiguityKind::kTiedLayouts};
  r.frame = std::make_shared<const Frame>();
  r.latency_ms = 60.0 + i % 13;
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 2000;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) reps = std::max(10, std::atoi(argv[++i]));
  }
  ServiceHealth health;
  health.triggers = 123456;
  health.camera_ok = true;
  modbus::ServerStats stats;
  stats.requests = 98765432;
  Metrics metrics(MetricsSource{[&health] { return health; }, [&stats] { return stats; },
                                [] { return std::string("0123456789abcdef"); }},
                  BuildInfo{"0.1.0", "abcdef012345"});
  std::vector<double> observe_us;
  for (int i = 0; i < reps; ++i) {
    const ResultSnapshot r = typical_result(i);
    const auto t0 = Clock::now();
    metrics.observe(r);
    observe_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  std::vector<double> render_us;
  std::size_t bytes = 0;
  for (int i = 0; i < std::max(10, reps / 10); ++i) {
    const auto t0 = Clock::now();
    const std::string text = metrics.render();
    render_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    bytes = text.size();
  }
  std::printf("| what | median | max | size |\n|---|---|---|---|\n");
  std::printf("| observe() one result (pipeline thread) | %.1f us | %.1f us | |\n", median(observe_us),
              *std::max_element(observe_us.begin(), observe_us.end()));
  std::printf("| render() one scrape | %.0f us | %.0f us | %zu bytes |\n", median(render_us),
              *std::max_element(render_us.begin(), render_us.end()), bytes);
  return 0;
}
