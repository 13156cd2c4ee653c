// suggest_region_of_interest(): a simulated pallet with a cabinet and a post beside it.
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/roi_suggestion.hpp"
#include "palletd/sim/sim.hpp"

using namespace palletd;

namespace {

constexpr double kCabinetAboveLoad_m = 0.8;  // the cabinet's top above the load's top

struct Cell {
  sim::SimulatedFrame sim;
  sim::SimBox cabinet;
  sim::SimBox post;
};


sim::SimBox standing_box(const Eigen::Vector2d& center_m, double long_m, double short_m, double top_z_m) {
  sim::SimBox b;
  b.center = center_m;
  b.long_m = long_m;
  b.short_m = short_m;
  b.bottom_z_m = 0.0;
  b.top_z_m = top_z_m;
  b.reflectance = 0.4;
  b.format_index = -1;  // not a box of the load
  return b;
}

/// A EUR pallet with two layers of 400 x 300 x 250 boxes; a cabinet `gap_m` beside its +x end,
/// 0.8 m taller than the load, and a thin post off its -x/+y corner. The camera looks down from
/// 3.5 m, 5 deg off vertical.
Cell make_cell(double gap_m) {
  const sim::SensorProfile profile = *sim::profile_by_name("o3d303");
  sim::ScenarioOptions options;
  options.pattern = sim::PatternFamily::kBlock;
  options.formats = {*sim::parse_format("400x300x250")};
  options.lower_layers_min = options.lower_layers_max = 1;
  sim::Scene scene = *sim::make_scene(options, profile, 11);
  Cell cell;
  const double load_top_m = scene.top_z_m;
  cell.cabinet = standing_box(Eigen::Vector2d(0.5 * scene.pallet_long_m + gap_m + 0.3, 0.0), 0.6, 0.5,
                              load_top_m + kCabinetAboveLoad_m);
  cell.post = standing_box(Eigen::Vector2d(-0.9, 0.6), 0.1, 0.1, 1.3);
  scene.boxes.push_back(cell.cabinet);
  scene.boxes.push_back(cell.post);
  scene.T_world_camera = sim::camera_looking_at(Eigen::Vector3d(0.0, 0.1, 3.5), Eigen::Vector3d(0.3, 0.0, 0.0));
  cell.sim = sim::render(scene, profile, 5);
  return cell;
}

/// Whether the axis-aligned footprint of `b` (yaw 0) overlaps the region's x-y.
bool overlaps_xy(const sim::SimBox& b, const RegionOfInterest& roi) {
  return b.center.x() + 0.5 * b.long_m > roi.min_m.x() && b.center.x() - 0.5 * b.long_m < roi.max_m.x() &&
         b.center.y() + 0.5 * b.short_m > roi.min_m.y() && b.center.y() - 0.5 * b.short_m < roi.max_m.y();
}

/// The highest truth box top in the base frame (the scene's world: floor at z = 0) [m].
double highest_truth_z_m(const Cell& cell, const Eigen::Isometry3d& T_base_camera) {
  double top_m = -1e9;
  for (const TruthBox& t : cell.sim.truth.boxes) top_m = std::max(top_m, (T_base_camera * t.center).z());
  return top_m;
}

}  // namespace

TEST_CASE("roi suggestion: the pallet's box, without the cabinet and the post beside it") {
  const Cell cell = make_cell(0.2);
  const Frame& frame = cell.sim.frame;
  REQUIRE(frame.T_base_camera);
  REQUIRE_FALSE(cell.sim.truth.boxes.empty());
  const RoiSuggestion s = suggest_region_of_interest(frame, frame.T_base_camera);
  INFO(s.message);
  REQUIRE(s.ok);
  CHECK(s.roi.frame == RegionOfInterest::Frame::kBase);
  CHECK_FALSE(s.camera_fallback);
  CHECK(s.floor_z_m == Approx(0.0).margin(0.01));
  for (const TruthBox& t : cell.sim.truth.boxes) {
    const Eigen::Vector3d p = *frame.T_base_camera * t.center;
    INFO("box centre " << p.transpose());
    CHECK(s.roi.contains(p));
  }
  CHECK_FALSE(overlaps_xy(cell.cabinet, s.roi));
  CHECK_FALSE(overlaps_xy(cell.post, s.roi));
  const double top_m = highest_truth_z_m(cell, *frame.T_base_camera);
  CHECK(s.load_top_z_m == Approx(top_m).margin(0.02));
  CHECK(s.roi.max_m.z() > top_m);
  CHECK(s.roi.max_m.z() < cell.cabinet.top_z_m);
  CHECK(s.roi.min_m.z() == Approx(0.1).margin(0.01));
  CHECK(s.excluded_objects == 2);
  // The footprint is the pallet's (EUR 1.2 x 0.8 m), not the pallet with its neighbours.
  CHECK(s.footprint_size_m.x() == Approx(1.2).margin(0.06));
  CHECK(s.footprint_size_m.y() == Approx(0.8).margin(0.06));
  CHECK(s.footprint_m.size() >= 4);
}

TEST_CASE("roi suggestion: a cabinet touching the pallet is split off by its height") {
  const Cell cell = make_cell(0.0);
  const Frame& frame = cell.sim.frame;
  const RoiSuggestion s = suggest_region_of_interest(frame, frame.T_base_camera);
  INFO(s.message);
  REQUIRE(s.ok);
  for (const TruthBox& t : cell.sim.truth.boxes) CHECK(s.roi.contains(*frame.T_base_camera * t.center));
  // Only the margin reaches over the cabinet, not its footprint.
  const double cabinet_near_x_m = cell.cabinet.center.x() - 0.5 * cell.cabinet.long_m;
  CHECK(s.roi.max_m.x() < cabinet_near_x_m + 0.1 + 0.03);
  CHECK(s.footprint_size_m.x() < 1.3);
  CHECK(s.roi.max_m.z() < cell.cabinet.top_z_m);
  CHECK(s.excluded_objects >= 1);
}

TEST_CASE("roi suggestion: --max-load-height-m sets z max from the floor") {
  const Cell cell = make_cell(0.2);
  RoiSuggestionOptions options;
  options.max_load_height_m = 1.8;
  const RoiSuggestion s = suggest_region_of_interest(cell.sim.frame, cell.sim.frame.T_base_camera, options);
  REQUIRE(s.ok);
  CHECK(s.roi.max_m.z() == Approx(s.floor_z_m + 1.8).margin(1e-9));
  options.max_load_height_m = 0.2;  // below the load's top: top + above instead, and said so
  const RoiSuggestion low = suggest_region_of_interest(cell.sim.frame, cell.sim.frame.T_base_camera, options);
  REQUIRE(low.ok);
  CHECK(low.roi.max_m.z() == Approx(low.load_top_z_m + options.above_m).margin(1e-9));
  CHECK_THAT(low.message, Catch::Contains("maximum load height"));
}

TEST_CASE("roi suggestion: without camera_to_base the region falls back to the camera frame") {
  Cell cell = make_cell(0.2);
  const Eigen::Isometry3d T_camera_base = cell.sim.frame.T_base_camera->inverse();
  cell.sim.frame.T_base_camera.reset();
  const RoiSuggestion s = suggest_region_of_interest(cell.sim.frame, std::nullopt);
  INFO(s.message);
  REQUIRE(s.ok);
  CHECK(s.camera_fallback);
  CHECK(s.roi.frame == RegionOfInterest::Frame::kCamera);
  CHECK_THAT(s.message, Catch::Contains("camera frame"));
  for (const TruthBox& t : cell.sim.truth.boxes) CHECK(s.roi.contains(t.center));
  // The cabinet's top centre stands beside or above the region: left out (not kept as "below").
  const Eigen::Vector3d cabinet_top =
      T_camera_base * Eigen::Vector3d(cell.cabinet.center.x(), cell.cabinet.center.y(), cell.cabinet.top_z_m);
  CHECK_FALSE(s.roi.contains(cabinet_top));
  CHECK(cabinet_top.z() <= s.roi.max_m.z());
  // The floor fitted in the camera frame is the real floor: the load stands as high above it.
  CHECK(s.load_top_z_m - s.floor_z_m ==
        Approx(highest_truth_z_m(cell, T_camera_base.inverse())).margin(0.03));
}
