// The cell's health figures of one frame (detection/health.hpp): pixels without depth and
// saturated pixels inside the region of interest, mixed pixels at the layer's edges, the layer
// plane's noise against the camera's model.
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/health.hpp"
#include "palletd/sim/sim.hpp"

#include "sim_block_layer.hpp"

using namespace palletd;
using palletd::testing::formats_of;

namespace {

/// A flat wall 1.5 m in front of a 160 x 120 camera, 1 mm depth units, 16-bit intensity.
Frame flat_frame() {
  Frame f;
  f.intrinsics = Intrinsics{160, 120, 150.0, 150.0, 80.0, 60.0, std::nullopt};
  f.depth.assign(f.pixel_count(), 1500);
  f.intensity.assign(f.pixel_count(), 1000);
  f.intensity_bits = 16;
  return f;
}

/// Camera-frame region 0.6 m x 0.4 m x 1 m: its near face (z = 1 m) covers u 35..125, v 30..90.
RegionOfInterest camera_roi() {
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kCamera;
  roi.min_m = Eigen::Vector3d(-0.3, -0.2, 1.0);
  roi.max_m = Eigen::Vector3d(0.3, 0.2, 2.0);
  return roi;
}

sim::SimulatedFrame render_block(std::uint64_t seed, const sim::RenderOptions& render = {}) {
  const sim::SensorProfile profile = *sim::profile_by_name("o3d303");
  sim::ScenarioOptions options;
  options.pattern = sim::PatternFamily::kBlock;
  options.formats = {*sim::parse_format("400x300x250")};
  const Expected<sim::Scene> scene = sim::make_scene(options, profile, seed);
  REQUIRE(scene);
  return sim::render(*scene, profile, seed, render);
}

}  // namespace

TEST_CASE("health: pixels without depth and saturated pixels count inside the region of interest only",
          "[health]") {
  Frame f = flat_frame();
  const RegionOfInterest roi = camera_roi();
  for (int v = 0; v < 120; ++v)
    for (int u = 0; u < 20; ++u) f.depth[static_cast<std::size_t>(v * 160 + u)] = 0;  // outside the region
  const FrameHealth clean = measure_frame_health(f, &roi, LayerResult{}, DepthNoiseModel{});
  REQUIRE(clean.measured);
  CHECK(clean.roi_pixels > 5000);
  CHECK(clean.roi_pixels < 6000);
  CHECK(clean.invalid_fraction == 0.0);
  REQUIRE(clean.saturated_fraction);
  CHECK(*clean.saturated_fraction == 0.0);

  for (int v = 30; v <= 90; ++v) {
    for (int u = 35; u <= 125; ++u) {
      const auto i = static_cast<std::size_t>(v * 160 + u);
      if (u % 10 == 0) f.depth[i] = 0;
      if (u % 20 == 5) f.intensity[i] = 65535;
    }
  }
  const FrameHealth dirty = measure_frame_health(f, &roi, LayerResult{}, DepthNoiseModel{});
  CHECK(dirty.invalid_fraction == Approx(0.1).margin(0.01));
  CHECK(*dirty.saturated_fraction == Approx(0.05).margin(0.01));
  // Without a layer there is no edge and no plane to judge.
  CHECK_FALSE(dirty.flying_fraction);
  CHECK_FALSE(dirty.plane_noise_mm);

  // Without a region every pixel counts; without intensity there is no saturation figure.
  f.intensity.clear();
  f.intensity_bits = 0;
  const FrameHealth whole = measure_frame_health(f, nullptr, LayerResult{}, DepthNoiseModel{});
  CHECK(whole.roi_pixels == f.pixel_count());
  CHECK(whole.invalid_fraction > dirty.invalid_fraction);
  CHECK_FALSE(whole.saturated_fraction);
}

TEST_CASE("health: detect() measures every readable frame, a blind one too", "[health]") {
  Frame blind = flat_frame();
  std::fill(blind.depth.begin(), blind.depth.end(), std::uint16_t{0});
  const Detection d = detect(blind, {BoxFormat{0.4, 0.3, "b", 0.0}}, DetectionParams{});
  CHECK(is_failure(d.status));
  REQUIRE(d.health.measured);
  CHECK(d.health.invalid_fraction == 1.0);
  CHECK(d.timing_ms.count("health") == 1);

  Frame unreadable = flat_frame();
  unreadable.depth.resize(10);
  CHECK_FALSE(detect(unreadable, {BoxFormat{0.4, 0.3, "b", 0.0}}, DetectionParams{}).health.measured);
}

TEST_CASE("health: mixed pixels at the layer's edges are flying, a camera without them shows few",
          "[health]") {
  // The simulator mixes depths inside a pixel that straddles an edge (supersampling), as a
  // time-of-flight pixel does; with one ray per pixel there is no mixing.
  const sim::SimulatedFrame mixed = render_block(5);
  sim::RenderOptions one_ray;
  one_ray.supersampling = 1;
  const sim::SimulatedFrame sharp = render_block(5, one_ray);
  const Detection with_mixing = detect(mixed.frame, formats_of(mixed), DetectionParams{});
  const Detection without = detect(sharp.frame, formats_of(sharp), DetectionParams{});
  REQUIRE(with_mixing.health.flying_fraction);
  REQUIRE(without.health.flying_fraction);
  CAPTURE(*with_mixing.health.flying_fraction, *without.health.flying_fraction);
  CHECK(*with_mixing.health.flying_fraction > 0.15);
  // What stays are jumps whose both sides are real (a step seen through a pixel's corner).
  CHECK(*with_mixing.health.flying_fraction > 2.5 * *without.health.flying_fraction);
}

TEST_CASE("health: the layer plane's noise against the camera's model", "[health]") {
  DetectionParams params;
  params.noise_model = DepthNoiseModel{2.0, 1.0};
  const sim::SimulatedFrame calm = render_block(8);
  sim::RenderOptions noisy_render;
  noisy_render.noise_scale = 3.0;
  const sim::SimulatedFrame noisy = render_block(8, noisy_render);
  const Detection a = detect(calm.frame, formats_of(calm), params);
  const Detection b = detect(noisy.frame, formats_of(noisy), params);
  REQUIRE(a.health.noise_ratio);
  REQUIRE(b.health.noise_ratio);
  REQUIRE(a.health.model_noise_mm);
  // The model at the layer's range (about 2 m from this camera): 2 mm x range / 1 m.
  CHECK(*a.health.model_noise_mm == Approx(2.0 * std::abs(a.plane_camera.d)).epsilon(0.1));
  CAPTURE(*a.health.plane_noise_mm, *b.health.plane_noise_mm);
  CHECK(*b.health.noise_ratio > 2.0 * *a.health.noise_ratio);

  params.noise_model = DepthNoiseModel{};  // no model: the noise is measured, not compared
  const Detection c = detect(calm.frame, formats_of(calm), params);
  CHECK(c.health.plane_noise_mm);
  CHECK_FALSE(c.health.noise_ratio);
}
