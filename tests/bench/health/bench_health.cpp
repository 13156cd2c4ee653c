// palletd_bench_health [--count N] [--reps R] [--seed S]
// Cost of the per-frame cell health figures (measure_frame_health) and of the drift measurement
// (measure_drift, a later frame from a camera turned by 0.5 degrees against the first one's
// reference) on 640 x 480 simulator frames of cells, for docs/benchmarks.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/drift.hpp"
#include "palletd/detection/health.hpp"
#include "palletd/sim/sim.hpp"

using namespace palletd;

namespace {

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)))];
}

template <typename F>
double time_ms(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

struct Args {
  int count = 6;
  int reps = 50;
  std::uint64_t seed = 1;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--count")
      a.count = std::atoi(argv[i + 1]);
    else if (k == "--reps")
      a.reps = std::atoi(argv[i + 1]);
    else if (k == "--seed")
      a.seed = std::strtoull(argv[i + 1], nullptr, 10);
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  std::printf("| profile | frames | health median ms | health p99 ms | drift median ms | drift p99 ms |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (const std::string name : {"helios2", "blaze101", "d435"}) {
    const sim::SensorProfile profile = *sim::profile_by_name(name);
    std::vector<double> health_ms, drift_ms;
    int frames = 0;
    for (int i = 0; i < args.count; ++i) {
      sim::ScenarioOptions options;
      options.scene = sim::SceneFamily::kCell;
      const Expected<sim::Scene> scene =
          sim::make_scene(options, profile, args.seed + static_cast<std::uint64_t>(i));
      if (!scene || !scene->has_roi) continue;
      const sim::SimulatedFrame f = sim::render(*scene, profile, args.seed + static_cast<std::uint64_t>(i));
      RegionOfInterest roi;
      roi.min_m = scene->roi_min_m;
      roi.max_m = scene->roi_max_m;
      DetectionParams params;
      params.roi = roi;
      params.noise_model = DepthNoiseModel{1.0, 1.0};
      std::vector<BoxFormat> formats;
      for (const auto& r : scene->recipe) formats.push_back(BoxFormat{r.long_m, r.short_m, r.name, 0.0});
      const Detection d = detect(f.frame, formats, params);
      const Expected<DriftReference> reference = DriftReference::from_frame(f.frame, roi);
      ++frames;
      for (int r = 0; r < args.reps; ++r) {
        health_ms.push_back(
            time_ms([&] { (void)measure_frame_health(f.frame, &roi, d.layer, params.noise_model); }));
      }
      if (!reference) continue;
      // A later frame of the same cell (other noise) from a camera turned by 0.5 degrees.
      sim::Scene moved = *scene;
      moved.T_world_camera = scene->T_world_camera * Eigen::AngleAxisd(0.5 * M_PI / 180.0, Eigen::Vector3d::UnitX());
      const sim::SimulatedFrame later = sim::render(moved, profile, args.seed + 1000 + static_cast<std::uint64_t>(i));
      for (int r = 0; r < std::max(1, args.reps / 10); ++r)
        drift_ms.push_back(time_ms([&] { (void)measure_drift(later.frame, *reference); }));
    }
    std::printf("| %s | %d | %.3f | %.3f | %.2f | %.2f |\n", name.c_str(), frames, quantile(health_ms, 0.5),
                quantile(health_ms, 0.99), quantile(drift_ms, 0.5), quantile(drift_ms, 0.99));
  }
  return 0;
}
