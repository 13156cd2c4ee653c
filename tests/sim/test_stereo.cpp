// The active-stereo profile (issue 19): no mixed pixels, occlusion shadows on one side.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "sim_test_util.hpp"

using namespace palletd;
using namespace palletd::sim;

namespace {

/// One box (top `height_m` above the floor) right under a camera 1.5 m up looking straight down.
Scene box_scene(double height_m, double yaw_rad) {
  Scene scene = test::floor_scene(1.5, 0.0, 0.3);
  SimBox box;
  box.center = Eigen::Vector2d(0.013, -0.021);
  box.yaw_rad = yaw_rad;
  box.long_m = 0.6;
  box.short_m = 0.4;
  box.top_z_m = height_m;
  box.format = "600x400";
  box.format_index = 0;
  scene.boxes.push_back(box);
  scene.top_layer.push_back(0);
  scene.top_z_m = height_m;
  return scene;
}

}  // namespace

TEST_CASE("d435 is a listed active-stereo profile") {
  const auto names = profile_names();
  CHECK(std::find(names.begin(), names.end(), "d435") != names.end());
  const SensorProfile p = *profile_by_name("d435");
  CHECK(p.kind == SensorKind::kActiveStereo);
  CHECK(p.intrinsics.width == 640);
  CHECK(p.intrinsics.height == 480);
  CHECK(stereo_sigma_m(p, 2.0) > 0.001 * 2.0);
  CHECK(stereo_sigma_m(p, 2.0) < 0.0025 * 2.0);
}

TEST_CASE("d435-hd is the D435's 1280x720 mode: half its depth noise, not among the profiles `all` draws") {
  const SensorProfile sd = *profile_by_name("d435");
  const SensorProfile hd = *profile_by_name("d435-hd");
  CHECK(hd.kind == SensorKind::kActiveStereo);
  CHECK(hd.intrinsics.width == 1280);
  CHECK(hd.intrinsics.height == 720);
  CHECK(hd.camera_id != sd.camera_id);
  // The matching's sub-pixel noise is in pixels: twice the focal length, half the depth noise.
  CHECK(stereo_sigma_m(hd, 2.0) == Approx(0.5 * stereo_sigma_m(sd, 2.0)).epsilon(0.01));
  const auto names = profile_names();
  CHECK(std::find(names.begin(), names.end(), "d435-hd") == names.end());
}

TEST_CASE("active stereo renders no mixed pixels at box edges") {
  const Scene scene = box_scene(0.25, 0.3);
  const SensorProfile p = *profile_by_name("d435");
  RenderOptions r = test::noise_free();
  r.supersampling = 0;  // the profile's 3x3 rays
  const SimulatedFrame sim = render(scene, p, 8, r);
  std::size_t top = 0, floor = 0, between = 0;
  for (std::size_t i = 0; i < sim.frame.depth.size(); ++i) {
    if (sim.frame.depth[i] == 0) continue;
    const double z = sim.frame.depth[i] * sim.frame.depth_scale_m;
    if (std::abs(z - 1.25) < 0.003) {
      ++top;
    } else if (z > 1.25 && z < 1.5 + 0.5) {
      // The floor's Z is 1.5 everywhere under a camera looking straight down.
      ++(std::abs(z - 1.5) < 0.003 ? floor : between);
    } else {
      ++between;
    }
  }
  CHECK(top > 1000);
  CHECK(floor > 1000);
  CHECK(between == 0);
}

TEST_CASE("active stereo leaves occlusion holes on one side of a depth step only") {
  const Scene scene = box_scene(0.8, 0.0);  // 0.7 m to the top, 1.5 m to the floor
  SensorProfile p = *profile_by_name("d435");
  p.invalid_min = p.invalid_max = 0.0;  // shadows only
  RenderOptions r = test::noise_free();
  r.invalid = true;
  const SimulatedFrame sim = render(scene, p, 3, r);
  // The box's image spans columns around the centre; count holes left and right of its middle.
  const Intrinsics& k = p.intrinsics;
  std::size_t left = 0, right = 0;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u)
      if (sim.frame.depth[static_cast<std::size_t>(v * k.width + u)] == 0) ++(u < k.cx ? left : right);
  INFO("left " << left << ", right " << right);
  CHECK(std::max(left, right) > 500);    // a band ~10 px wide along a 200 px edge
  CHECK(std::min(left, right) == 0);
  // The same scene without the invalid model has none.
  RenderOptions clean = test::noise_free();
  const SimulatedFrame without = render(scene, p, 3, clean);
  std::size_t holes = 0;
  for (std::uint16_t d : without.frame.depth) holes += d == 0 ? 1 : 0;
  CHECK(holes == 0);
}

TEST_CASE("active stereo washes out narrow seams and keeps wide gaps") {
  // Two boxes with a 6 mm seam (about one pixel at 1.25 m) and, beside, two with a 40 mm gap.
  Scene scene = test::floor_scene(1.5, 0.0, 0.3);
  auto add = [&](double x, double y) {
    SimBox b;
    b.center = Eigen::Vector2d(x, y);
    b.long_m = 0.3;
    b.short_m = 0.2;
    b.top_z_m = 0.25;
    b.format_index = 0;
    scene.boxes.push_back(b);
  };
  add(-0.153, -0.15);
  add(0.153, -0.15);  // seam 6 mm
  add(-0.17, 0.15);
  add(0.17, 0.15);    // gap 40 mm
  const SensorProfile p = *profile_by_name("d435");
  RenderOptions r = test::noise_free();
  r.supersampling = 0;
  const SimulatedFrame sim = render(scene, p, 5, r);
  const Intrinsics& k = p.intrinsics;
  auto deep_in_row = [&](double y_world) {
    // Camera y points along -world y in look_down(), so find the row by projecting.
    Eigen::Vector2d px;
    project(k, scene.T_world_camera.inverse() * Eigen::Vector3d(0.0, y_world, 0.25), px);
    const int v = static_cast<int>(std::lround(px.y()));
    int deep = 0;
    for (int u = static_cast<int>(k.cx) - 15; u <= static_cast<int>(k.cx) + 15; ++u)
      if (sim.frame.depth[static_cast<std::size_t>(v * k.width + u)] * sim.frame.depth_scale_m > 1.3) ++deep;
    return deep;
  };
  CHECK(deep_in_row(-0.15) == 0);
  CHECK(deep_in_row(0.15) >= 3);
}
