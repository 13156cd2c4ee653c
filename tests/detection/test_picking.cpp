// What the gripper can take now (detection/picking.hpp): pickable boxes and why the others are
// not, TCP poses, the pick order and pick groups, on simulated layers with the region of
// interest's walls, a post standing higher than the layer, yaw limits and wide grippers.
#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/picking.hpp"
#include "palletd/sim/sim.hpp"
#include "sim_block_layer.hpp"

using namespace palletd;

namespace {

using testing::block_layer_scene;

double top_z(const sim::Scene& scene) {
  double z = 0.0;
  for (const std::size_t i : scene.top_layer) z = std::max(z, scene.boxes[i].top_z_m);
  return z;
}

/// The pallet's footprint grown by `margin_m`, from below the deck to 0.6 m above the load.
RegionOfInterest roi_around(const sim::Scene& scene, double margin_m) {
  RegionOfInterest roi;
  roi.min_m =
      Eigen::Vector3d(-0.5 * scene.pallet_long_m - margin_m, -0.5 * scene.pallet_short_m - margin_m, 0.05);
  roi.max_m = Eigen::Vector3d(0.5 * scene.pallet_long_m + margin_m, 0.5 * scene.pallet_short_m + margin_m,
                              top_z(scene) + 0.6);
  return roi;
}

Detection detect_with(const sim::SimulatedFrame& f, const DetectionParams& params) {
  std::vector<BoxFormat> formats;
  for (const auto& r : f.scene.recipe) formats.push_back(BoxFormat{r.long_m, r.short_m, r.name, 0.0});
  Detection d = detect(f.frame, formats, params);
  INFO(d.message);
  REQUIRE(d.status == DetectionStatus::kOk);
  REQUIRE(d.boxes.size() == f.truth.boxes.size());
  return d;
}

GripperParams gripper_mm(double long_mm, double short_mm) {
  GripperParams g;
  g.footprint_mm = Eigen::Vector2d(long_mm, short_mm);
  return g;
}

/// The pick indices are 0..n-1 in the boxes' order, pickable boxes first.
void check_order(const Detection& d) {
  bool seen_blocked = false;
  for (std::size_t i = 0; i < d.boxes.size(); ++i) {
    CHECK(d.boxes[i].pick_index == static_cast<int>(i));
    REQUIRE(d.boxes[i].pick);
    if (!d.boxes[i].pick->pickable)
      seen_blocked = true;
    else
      CHECK_FALSE(seen_blocked);
  }
}

}  // namespace

TEST_CASE("a gripper the size of a box takes every box of a free-standing layer, one per group",
          "[picking]") {
  const sim::SimulatedFrame f = sim::render(block_layer_scene(401), *sim::profile_by_name("helios2"), 401);
  DetectionParams params;
  params.gripper = gripper_mm(400, 300);
  params.gripper->tcp_offset_mm = Eigen::Vector2d(50.0, 0.0);
  params.gripper->yaw_min_deg = -90.0;
  params.gripper->yaw_max_deg = 90.0;
  const Detection d = detect_with(f, params);
  check_order(d);
  REQUIRE(d.groups.size() == d.boxes.size());
  for (std::size_t g = 0; g < d.groups.size(); ++g) {
    CHECK(d.groups[g].pick_index == static_cast<int>(g));
    REQUIRE(d.groups[g].boxes.size() == 1);
  }
  for (const DetectedBox& b : d.boxes) {
    REQUIRE(b.pick);
    CHECK(b.pick->pickable);
    CHECK(b.pick->blocked_by == PickBlock::kNone);
    const TcpPose& tcp = b.pick->tcp;
    CHECK(tcp.base_frame);
    CHECK(tcp.yaw_deg >= -90.0);
    CHECK(tcp.yaw_deg <= 90.0);
    // The TCP is 50 mm from the box's centre along its long side, at the box's top.
    REQUIRE(b.base_position);
    const Eigen::Vector3d offset = tcp.position_m - *b.base_position;
    CHECK(offset.norm() == Approx(0.050).margin(0.002));
    const double yaw_rad = tcp.yaw_deg * M_PI / 180.0;
    CHECK(offset.head<2>().dot(Eigen::Vector2d(std::cos(yaw_rad), std::sin(yaw_rad))) ==
          Approx(0.050).margin(0.002));
  }
}

TEST_CASE("a post higher than the layer blocks the boxes under the footprint's clearance", "[picking]") {
  sim::Scene scene = block_layer_scene(402);
  // A pallet stop: an 80 mm square post 40 mm off the pallet's +x end, 0.3 m above the load.
  sim::SimBox post;
  post.center = Eigen::Vector2d(0.5 * scene.pallet_long_m + 0.08, 0.0);
  post.long_m = post.short_m = 0.08;
  post.top_z_m = top_z(scene) + 0.3;
  post.reflectance = 0.5;
  scene.boxes.push_back(post);
  const sim::SimulatedFrame f = sim::render(scene, *sim::profile_by_name("helios2"), 402);
  DetectionParams params;
  params.roi = roi_around(scene, 0.15);
  params.gripper = gripper_mm(400, 300);
  params.gripper->clearance_mm = 60.0;
  const Detection d = detect_with(f, params);
  check_order(d);
  int blocked = 0;
  for (const DetectedBox& b : d.boxes) {
    REQUIRE(b.base_position);
    // The box's +x end reaches within the clearance of the post's face (box half length 0.2 m).
    const bool near_post = b.base_position->x() + 0.2 + 0.06 > post.center.x() - 0.04 &&
                           std::abs(b.base_position->y()) < 0.15 + 0.06 + 0.04 + 0.01;
    CAPTURE(b.base_position->transpose());
    if (near_post) {
      CHECK_FALSE(b.pick->pickable);
      CHECK(b.pick->blocked_by == PickBlock::kHigherLevel);
      ++blocked;
    } else if (std::abs(b.base_position->x() + 0.2 + 0.06 - (post.center.x() - 0.04)) > 0.02) {
      CHECK(b.pick->pickable);
    }
  }
  CHECK(blocked >= 1);
  // The blocked boxes are in no group.
  for (const PickGroup& g : d.groups)
    for (const int i : g.boxes) CHECK(d.boxes[static_cast<std::size_t>(i)].pick->pickable);
}

TEST_CASE("the region of interest's walls block a footprint that reaches past them", "[picking]") {
  const sim::Scene scene = block_layer_scene(403);
  const sim::SimulatedFrame f = sim::render(scene, *sim::profile_by_name("helios2"), 403);
  DetectionParams params;
  params.roi = roi_around(scene, 0.03);
  params.gripper = gripper_mm(400, 300);
  params.gripper->clearance_mm = 50.0;  // reaches 20 mm past the wall at the layer's edge
  const Detection d = detect_with(f, params);
  check_order(d);
  int at_wall = 0;
  for (const DetectedBox& b : d.boxes) {
    const Eigen::Vector3d p = *b.base_position;
    const double margin_m = std::min({p.x() - params.roi->min_m.x(), params.roi->max_m.x() - p.x(),
                                      p.y() - params.roi->min_m.y(), params.roi->max_m.y() - p.y()});
    CAPTURE(p.transpose(), margin_m);
    // A box in the middle of the layer keeps 0.15 m + the clearance from every wall.
    if (margin_m > 0.30) {
      CHECK(b.pick->pickable);
    } else if (margin_m < 0.20) {
      CHECK(b.pick->blocked_by == PickBlock::kRoi);
      ++at_wall;
    }
  }
  CHECK(at_wall >= 4);
}

TEST_CASE("yaw limits: a box is taken at the one of its two yaws the robot reaches, or not at all",
          "[picking]") {
  const sim::SimulatedFrame f = sim::render(block_layer_scene(404), *sim::profile_by_name("helios2"), 404);
  DetectionParams params;
  params.gripper = gripper_mm(400, 300);
  params.gripper->yaw_min_deg = 150.0;
  params.gripper->yaw_max_deg = 210.0;
  Detection d = detect_with(f, params);
  for (const DetectedBox& b : d.boxes) {
    const double yaw = b.pick->tcp.yaw_deg;
    CAPTURE(yaw, *b.base_yaw_deg);
    const bool reachable = std::abs(std::remainder(*b.base_yaw_deg - 180.0, 180.0)) <= 30.0;
    if (reachable) {
      CHECK(b.pick->pickable);
      CHECK(std::abs(std::remainder(yaw - 180.0, 360.0)) <= 30.0 + 1e-9);
    }
  }
  // Turned by 90° from the boxes (a block layer: all turned alike), no box can be reached.
  const double across_deg = *d.boxes.front().base_yaw_deg + 90.0;
  params.gripper->yaw_min_deg = across_deg - 30.0;
  params.gripper->yaw_max_deg = across_deg + 30.0;
  d = detect_with(f, params);
  for (const DetectedBox& b : d.boxes) {
    CHECK_FALSE(b.pick->pickable);
    CHECK(b.pick->blocked_by == PickBlock::kYawLimits);
  }
  CHECK(d.groups.empty());
}

TEST_CASE("a wide gripper takes rows of boxes, or one box from the layer's edge", "[picking]") {
  const sim::SimulatedFrame f = sim::render(block_layer_scene(405), *sim::profile_by_name("helios2"), 405);
  DetectionParams params;
  params.gripper = gripper_mm(820, 310);  // two 400x300 cartons end to end
  params.gripper->max_boxes = 2;
  Detection d = detect_with(f, params);
  check_order(d);
  REQUIRE_FALSE(d.groups.empty());
  std::vector<int> taken;
  int pairs = 0;
  for (const PickGroup& g : d.groups) {
    CHECK(std::is_sorted(g.boxes.begin(), g.boxes.end()));
    for (const int i : g.boxes) taken.push_back(i);
    if (g.boxes.size() != 2) continue;
    ++pairs;
    const DetectedBox& a = d.boxes[static_cast<std::size_t>(g.boxes[0])];
    const DetectedBox& b = d.boxes[static_cast<std::size_t>(g.boxes[1])];
    CHECK(a.format == b.format);
    // End to end along the long side, the TCP between them.
    const Eigen::Vector3d mid = 0.5 * (*a.base_position + *b.base_position);
    CHECK((g.tcp.position_m - mid).head<2>().norm() < 0.012);  // flush with a side of the pair at most
    CHECK((*a.base_position - *b.base_position).head<2>().norm() == Approx(0.40).margin(0.03));
  }
  CHECK(pairs >= 1);
  std::sort(taken.begin(), taken.end());
  CHECK(std::adjacent_find(taken.begin(), taken.end()) == taken.end());  // a box is in one group at most
  // Boxes in groups are pickable; pickable boxes are in a group.
  for (std::size_t i = 0; i < d.boxes.size(); ++i)
    CHECK(d.boxes[i].pick->pickable == std::binary_search(taken.begin(), taken.end(), static_cast<int>(i)));
}

TEST_CASE("a footprint larger than the box overhangs the layer's outside, never a neighbour", "[picking]") {
  const sim::SimulatedFrame f = sim::render(block_layer_scene(406), *sim::profile_by_name("helios2"), 406);
  DetectionParams params;
  // 100 mm wider than the box: the layer is four boxes across their short sides, two along.
  params.gripper = gripper_mm(400, 400);
  const Detection d = detect_with(f, params);
  check_order(d);
  REQUIRE(d.boxes.size() == 8);
  int pickable = 0;
  for (const DetectedBox& b : d.boxes) {
    // A box with neighbours along both long sides waits for one of them to go.
    if (b.pick->pickable)
      ++pickable;
    else
      CHECK(b.pick->blocked_by == PickBlock::kNeighbour);
  }
  CHECK(pickable == 4);
  // Each pickable box is taken from the outside: the footprint overhangs the layer, not a box.
  for (const PickGroup& g : d.groups) {
    REQUIRE(g.boxes.size() == 1);
    const DetectedBox& b = d.boxes[static_cast<std::size_t>(g.boxes[0])];
    CHECK((g.tcp.position_m - *b.base_position).head<2>().norm() == Approx(0.05).margin(0.005));
  }
}

TEST_CASE("obstacles above the layer: a post is one, a lone flying pixel is not, beside the region neither",
          "[picking]") {
  Frame frame;
  frame.intrinsics = Intrinsics{40, 30, 40.0, 40.0, 20.0, 15.0, std::nullopt};
  frame.depth.assign(frame.pixel_count(), 2000);  // a layer 2 m from the camera, mm units
  frame.depth[5 * 40 + 5] = 1500;                 // a lone flying pixel 0.5 m above it
  for (int v = 20; v < 24; ++v)
    for (int u = 30; u < 34; ++u) frame.depth[static_cast<std::size_t>(v * 40 + u)] = 1700;  // a post
  for (int v = 2; v < 6; ++v)
    for (int u = 1; u < 5; ++u) frame.depth[static_cast<std::size_t>(v * 40 + u)] = 1700;  // a cabinet beside
  const RayTable rays(frame.intrinsics);
  Eigen::Isometry3d T_camera_layer = Eigen::Isometry3d::Identity();
  T_camera_layer.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();  // layer z toward the camera
  T_camera_layer.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
  // Region: camera x from -0.6 m (the cabinet at u < 5 is at x < -0.75 m) to 1 m; its top at
  // 1.9 m from the camera cuts the post, which still counts.
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kCamera;
  roi.min_m = Eigen::Vector3d(-0.6, -1.0, 1.9);
  roi.max_m = Eigen::Vector3d(1.0, 1.0, 2.5);
  const std::vector<Eigen::Vector2d> obstacles =
      obstacles_above_layer(frame, rays, T_camera_layer, 0.03, &roi, std::nullopt);
  REQUIRE_FALSE(obstacles.empty());
  for (const Eigen::Vector2d& p : obstacles) {
    CHECK(p.x() > 0.4);   // camera x (u - 20) * 1.7 / 40 = 0.42..0.60
    CHECK(p.y() < -0.2);  // camera y 0.21..0.38, layer y flipped
  }
  // Without the region the cabinet counts too.
  const std::vector<Eigen::Vector2d> all =
      obstacles_above_layer(frame, rays, T_camera_layer, 0.03, nullptr, std::nullopt);
  CHECK(std::any_of(all.begin(), all.end(), [](const Eigen::Vector2d& p) { return p.x() < -0.6; }));
}

TEST_CASE(
    "obstacles above the layer: the ring of pixels a post's edge mixes is not the post, a thin bar is kept",
    "[picking]") {
  Frame frame;
  frame.intrinsics = Intrinsics{40, 30, 40.0, 40.0, 20.0, 15.0, std::nullopt};
  frame.depth.assign(frame.pixel_count(), 2000);  // a layer 2 m from the camera, mm units
  auto fill = [&](int u0, int u1, int v0, int v1, std::uint16_t depth_mm) {
    for (int v = v0; v <= v1; ++v)
      for (int u = u0; u <= u1; ++u) frame.depth[static_cast<std::size_t>(v * 40 + u)] = depth_mm;
  };
  // A post six pixels across 0.3 m above the layer, in a ring of pixels one wide that mix its top
  // with the layer (0.15 m above it, outside the post), and a bar two pixels wide.
  fill(23, 30, 9, 16, 1850);
  fill(24, 29, 10, 15, 1700);
  fill(5, 6, 5, 14, 1700);
  const RayTable rays(frame.intrinsics);
  Eigen::Isometry3d T_camera_layer = Eigen::Isometry3d::Identity();
  T_camera_layer.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  T_camera_layer.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
  const std::vector<Eigen::Vector2d> obstacles =
      obstacles_above_layer(frame, rays, T_camera_layer, 0.03, nullptr, std::nullopt);
  // The post: camera x (u - 20) * 1.7 / 40 = 0.17..0.38 m; the mixed ring at 0.14 and 0.46 m.
  std::vector<double> post_x_m;
  for (const Eigen::Vector2d& p : obstacles)
    if (p.x() > 0.0) post_x_m.push_back(p.x());
  REQUIRE_FALSE(post_x_m.empty());
  CHECK(*std::min_element(post_x_m.begin(), post_x_m.end()) > 0.16);
  CHECK(*std::max_element(post_x_m.begin(), post_x_m.end()) < 0.39);
  // The bar at camera x -0.64..-0.60 m stays an obstacle.
  CHECK(std::any_of(obstacles.begin(), obstacles.end(),
                    [](const Eigen::Vector2d& p) { return p.x() < -0.55; }));
}
