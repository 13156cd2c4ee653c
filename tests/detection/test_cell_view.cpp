// detect() on a layer the camera's view does not hold whole: a carton the image's edge cuts off
// (simulated scenes cropped the way a camera mounted off the pallet's middle sees them).
#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/sim/sim.hpp"

#include "sim_block_layer.hpp"

using namespace palletd;
using palletd::testing::kPalletTop_m;

namespace {

constexpr double kCartonHeight_m = 0.25;

sim::SimBox carton(const Eigen::Vector2d& center_m) {
  sim::SimBox b;
  b.center = center_m;
  b.long_m = 0.4;
  b.short_m = 0.3;
  b.bottom_z_m = kPalletTop_m;
  b.top_z_m = kPalletTop_m + kCartonHeight_m;
  b.bevel_m = 0.003;
  b.reflectance = 0.5;
  b.format_index = 0;
  b.format = "400x300";
  return b;
}

/// Three columns of two 400 x 300 cartons along the world's x axis, 30 mm apart (each carton a
/// piece of its own in the layer), seen from 1.3 m straight above the middle.
sim::SimulatedFrame six_cartons(const std::string& profile_name, std::uint64_t seed) {
  const sim::SensorProfile profile = *sim::profile_by_name(profile_name);
  sim::ScenarioOptions options;
  options.scene = sim::SceneFamily::kEmpty;
  sim::Scene scene = *sim::make_scene(options, profile, seed);
  for (const double x_m : {-0.43, 0.0, 0.43})
    for (const double y_m : {-0.165, 0.165}) scene.boxes.push_back(carton({x_m, y_m}));
  scene.top_layer.clear();
  for (std::size_t i = scene.boxes.size() - 6; i < scene.boxes.size(); ++i) scene.top_layer.push_back(i);
  scene.top_z_m = kPalletTop_m + kCartonHeight_m;
  scene.expect = "boxes";
  scene.recipe = {{"400x300", 0.4, 0.3, kCartonHeight_m}};
  scene.T_world_camera = sim::camera_looking_at(Eigen::Vector3d(0.0, 0.0, scene.top_z_m + 1.3),
                                                Eigen::Vector3d(0.0, 0.0, scene.top_z_m));
  return sim::render(scene, profile, seed);
}

/// The frame's image columns (or rows) [lo, hi): what a camera whose view ends there sees.
Frame crop(const Frame& frame, bool columns, int lo, int hi) {
  const Intrinsics& K = frame.intrinsics;
  Frame out = frame;
  out.intrinsics.width = columns ? hi - lo : K.width;
  out.intrinsics.height = columns ? K.height : hi - lo;
  (columns ? out.intrinsics.cx : out.intrinsics.cy) -= lo;
  out.depth.clear();
  out.intensity.clear();
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const int along = columns ? u : v;
      if (along < lo || along >= hi) continue;
      const auto i =
          static_cast<std::size_t>(v) * static_cast<std::size_t>(K.width) + static_cast<std::size_t>(u);
      out.depth.push_back(frame.depth[i]);
      if (frame.has_intensity()) out.intensity.push_back(frame.intensity[i]);
    }
  return out;
}

/// The frame cut to the side of the world line x = x_cut_m (on the layer's top) that holds
/// x = 0. The line must run along an image axis.
Frame cut_at_x(const sim::SimulatedFrame& f, double x_cut_m) {
  const Eigen::Isometry3d T_camera_world = f.scene.T_world_camera.inverse();
  const Intrinsics& K = f.frame.intrinsics;
  Eigen::Vector2d a, b, middle;
  REQUIRE(sim::project(K, T_camera_world * Eigen::Vector3d(x_cut_m, -0.3, f.scene.top_z_m), a));
  REQUIRE(sim::project(K, T_camera_world * Eigen::Vector3d(x_cut_m, 0.3, f.scene.top_z_m), b));
  REQUIRE(sim::project(K, T_camera_world * Eigen::Vector3d(0.0, 0.0, f.scene.top_z_m), middle));
  const bool columns = std::abs(a.x() - b.x()) < 2.0;  // the line runs down the image
  REQUIRE((columns || std::abs(a.y() - b.y()) < 2.0));
  const double cut = columns ? 0.5 * (a.x() + b.x()) : 0.5 * (a.y() + b.y());
  const bool keep_low = (columns ? middle.x() : middle.y()) < cut;
  const int extent = columns ? K.width : K.height;
  return keep_low ? crop(f.frame, columns, 0, static_cast<int>(std::floor(cut)))
                  : crop(f.frame, columns, static_cast<int>(std::ceil(cut)), extent);
}

}  // namespace

TEST_CASE("a carton the image's edge cuts to less than half a box flags the layout, a layer in view does not",
          "[cell][view]") {
  const std::vector<BoxFormat> formats = {{0.4, 0.3, "400x300"}};
  for (const char* profile : {"helios2", "d435"}) {
    const sim::SimulatedFrame f = six_cartons(profile, 31);
    const Detection whole = detect(f.frame, formats, DetectionParams{});
    CAPTURE(profile, whole.message, whole.ambiguity_reason);
    REQUIRE(whole.status == DetectionStatus::kOk);
    CHECK(whole.boxes.size() == 6);
    CHECK_FALSE(whole.ambiguous);

    // The right column's cartons keep 0.12 m of their 0.4 m: 0.3 of a box, a piece too small
    // to hold one. The four cartons in view are placed; the layout is flagged for the rest.
    const Detection cut = detect(cut_at_x(f, 0.43 - 0.2 + 0.12), formats, DetectionParams{});
    CAPTURE(cut.message, cut.ambiguity_reason);
    REQUIRE(cut.status == DetectionStatus::kOk);
    CHECK(cut.clipped_by_image_border);
    CHECK(cut.boxes.size() == 4);
    CHECK(cut.ambiguous);
    CHECK_THAT(cut.ambiguity_reason, Catch::Contains("image's edge cuts off part of the layer"));

    // The view ending in the gap beside the right column: every carton in view is whole.
    const Detection gap = detect(cut_at_x(f, 0.43 - 0.2 - 0.008), formats, DetectionParams{});
    CAPTURE(gap.message, gap.ambiguity_reason);
    REQUIRE(gap.status == DetectionStatus::kOk);
    CHECK(gap.boxes.size() == 4);
    CHECK_THAT(gap.ambiguity_reason, !Catch::Contains("image's edge"));
  }
}

TEST_CASE("the D435's 1280x720 mode: an interlock layer placed exactly, as at 640x480", "[cell][view]") {
  // Four times the pixels: every stage's pixel-based step (mixed pixels, the seam raster's cell,
  // the matching window's fattened edges) must scale with the pixel pitch.
  for (const char* profile : {"d435", "d435-hd"}) {
    const sim::SimulatedFrame f =
        testing::render_layer(sim::PatternFamily::kInterlock, "400x300x250", profile, 17, 0.004);
    DetectionParams params;
    params.layout.search.time_budget_ms = 1e6;  // the expansion budget alone ends the search (sanitizers)
    const Detection d = detect(f.frame, {{0.4, 0.3, "400x300"}}, params);
    CAPTURE(profile, d.message, d.ambiguity_reason);
    REQUIRE(d.status == DetectionStatus::kOk);
    CHECK_FALSE(d.ambiguous);
    REQUIRE(d.boxes.size() == f.truth.boxes.size());
    for (const TruthBox& t : f.truth.boxes) {
      double nearest_m = 1e9;
      for (const DetectedBox& b : d.boxes) nearest_m = std::min(nearest_m, (b.center - t.center).norm());
      CHECK(nearest_m < 0.01);
    }
  }
}
