// detect() on what a cell shows besides a full layer: the empty pallet, a slip sheet, a stepped
// pallet, and the layer's height above the pallet (simulated scenes, docs/simulator.md).
#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/sim/sim.hpp"

#include "level_checks.hpp"
#include "sim_block_layer.hpp"

using namespace palletd;
using palletd::testing::formats_of;
using palletd::testing::kPalletTop_m;

namespace {

sim::SimulatedFrame render_family(sim::SceneFamily family, const std::string& profile_name,
                                  std::uint64_t seed, const std::string& format = "400x300x250",
                                  int lower_layers = 1) {
  const sim::SensorProfile profile = *sim::profile_by_name(profile_name);
  sim::ScenarioOptions options;
  options.scene = family;
  options.pattern = sim::PatternFamily::kBlock;
  options.formats = {*sim::parse_format(format)};
  options.lower_layers_min = options.lower_layers_max = lower_layers;
  options.tilt_max_deg = 10.0;
  const Expected<sim::Scene> scene = sim::make_scene(options, profile, seed);
  REQUIRE(scene);
  return sim::render(*scene, profile, seed);
}

}  // namespace

TEST_CASE("an empty pallet is empty: by its deck boards, and by the pallet's height", "[cell][empty]") {
  for (const std::uint64_t seed : {3u}) {
    const sim::SimulatedFrame f = render_family(sim::SceneFamily::kEmpty, "o3d303", seed);
    REQUIRE(f.truth.boxes.empty());
    DetectionParams params;
    const Detection by_boards = detect(f.frame, formats_of(f), params);
    CAPTURE(seed, by_boards.message);
    CHECK(by_boards.status == DetectionStatus::kEmpty);
    CHECK_FALSE(is_failure(by_boards.status));  // an answer, not a failed frame
    CHECK(by_boards.boxes.empty());

    params.pallet.top_z_m = kPalletTop_m;
    const Detection by_height = detect(f.frame, formats_of(f, 0.25), params);
    CAPTURE(by_height.message);
    CHECK(by_height.status == DetectionStatus::kEmpty);
    REQUIRE(by_height.height_above_pallet_m);
    CHECK(std::abs(*by_height.height_above_pallet_m) < 0.02);
    CHECK(by_height.layers_remaining == 0);
  }
}

TEST_CASE("a level below the region of interest leaves it empty, inside it boxes", "[cell][empty]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "o3d303", 7);
  REQUIRE_FALSE(f.truth.boxes.empty());
  DetectionParams params;
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kBase;
  roi.min_m = Eigen::Vector3d(-1.0, -1.0, f.scene.top_z_m + 0.05);  // its floor above the load
  roi.max_m = Eigen::Vector3d(1.0, 1.0, f.scene.top_z_m + 1.0);
  params.roi = roi;
  const Detection above = detect(f.frame, formats_of(f), params);
  CAPTURE(above.message);
  CHECK(above.status == DetectionStatus::kEmpty);
  CHECK(above.boxes.empty());

  roi.min_m.z() = kPalletTop_m - 0.05;
  params.roi = roi;
  const Detection around = detect(f.frame, formats_of(f), params);
  CAPTURE(around.message);
  CHECK(around.status == DetectionStatus::kOk);
  CHECK(around.boxes.size() == f.truth.boxes.size());
}

TEST_CASE(
    "a station without a load: its floor cut by the region is empty, a layer at the region's floor is not",
    "[cell][empty]") {
  // No pallet: the cell's floor fills the region, which cuts it to a rectangle at its bottom.
  sim::ScenarioOptions options;
  options.scene = sim::SceneFamily::kEmpty;
  options.pallet = sim::PalletKind::kNone;
  options.cell = true;
  options.formats = {*sim::parse_format("400x300x250")};
  for (const char* profile_name : {"helios2", "xtion"}) {
    const sim::SensorProfile profile = *sim::profile_by_name(profile_name);
    const Expected<sim::Scene> scene = sim::make_scene(options, profile, 5);
    REQUIRE(scene);
    REQUIRE(scene->has_roi);
    const sim::SimulatedFrame f = sim::render(*scene, profile, 5);
    REQUIRE(f.truth.boxes.empty());
    DetectionParams params;
    params.roi = RegionOfInterest{RegionOfInterest::Frame::kBase, scene->roi_min_m, scene->roi_max_m};
    const Detection d = detect(f.frame, formats_of(f), params);
    CAPTURE(profile_name, d.message);
    CHECK(d.status == DetectionStatus::kEmpty);
    CHECK(d.boxes.empty());
  }
  // A layer of cartons whose top lies just above the region's bottom: boxes, inside the region's
  // sides and also with the sides drawn tight around it (the floor below the region beyond them
  // keeps its depth: the layer ends there, the region does not cut it).
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "helios2", 7);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e9), hi = Eigen::Vector2d::Constant(-1e9);
  for (const std::size_t k : f.scene.top_layer) {
    const sim::SimBox& b = f.scene.boxes[k];
    const Eigen::Rotation2Dd R(b.yaw_rad);
    for (const double sx : {-0.5, 0.5})
      for (const double sy : {-0.5, 0.5}) {
        const Eigen::Vector2d c = b.center + R * Eigen::Vector2d(sx * b.long_m, sy * b.short_m);
        lo = lo.cwiseMin(c);
        hi = hi.cwiseMax(c);
      }
  }
  for (const double margin_m : {0.3, 0.005}) {
    DetectionParams params;
    params.roi =
        RegionOfInterest{RegionOfInterest::Frame::kBase,
                         Eigen::Vector3d(lo.x() - margin_m, lo.y() - margin_m, f.scene.top_z_m - 0.05),
                         Eigen::Vector3d(hi.x() + margin_m, hi.y() + margin_m, f.scene.top_z_m + 1.0)};
    const Detection d = detect(f.frame, formats_of(f), params);
    CAPTURE(margin_m, d.message);
    CHECK(d.status == DetectionStatus::kOk);
    CHECK(d.boxes.size() == f.truth.boxes.size());
  }
}

TEST_CASE("layers left from the pallet's height and the boxes' height", "[cell][height]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "o3d303", 9, "400x300x250", 2);
  DetectionParams params;
  const Detection unknown = detect(f.frame, formats_of(f, 0.25), params);
  REQUIRE(unknown.status == DetectionStatus::kOk);
  CHECK_FALSE(unknown.height_above_pallet_m);
  CHECK_FALSE(unknown.layers_remaining);

  params.pallet.top_z_m = kPalletTop_m;
  const Detection no_heights = detect(f.frame, formats_of(f), params);
  REQUIRE(no_heights.height_above_pallet_m);
  CHECK(*no_heights.height_above_pallet_m == Approx(f.scene.top_z_m - kPalletTop_m).margin(0.01));
  CHECK_FALSE(no_heights.layers_remaining);  // the boxes' height is not configured

  const Detection three = detect(f.frame, formats_of(f, 0.25), params);
  REQUIRE(three.status == DetectionStatus::kOk);
  CHECK(three.layers_remaining == 3);
  CHECK_FALSE(three.height_off_layers);
  CHECK(three.ambiguous == unknown.ambiguous);

  // Boxes said to be 210 mm high: 0.75 m is 3.6 box heights, not a whole number of layers.
  const Detection off = detect(f.frame, formats_of(f, 0.21), params);
  CHECK(off.height_off_layers);
  CHECK(off.ambiguous);
  CHECK(off.ambiguity_reason.find("whole number") != std::string::npos);
  CHECK(std::count(off.ambiguity_kinds.begin(), off.ambiguity_kinds.end(), AmbiguityKind::kHeightOffLayers) == 1);
  CHECK(std::count(three.ambiguity_kinds.begin(), three.ambiguity_kinds.end(), AmbiguityKind::kHeightOffLayers) == 0);
  CHECK(three.ambiguous == !three.ambiguity_kinds.empty());
}

TEST_CASE("a slip sheet is never an unflagged layout, at a fine pitch it is a slip sheet", "[cell][sheet]") {
  for (const std::uint64_t seed : {5u}) {
    const sim::SimulatedFrame f = render_family(sim::SceneFamily::kSlipSheet, "helios2", seed);
    REQUIRE(f.truth.expect == "slip_sheet");
    const Detection d = detect(f.frame, formats_of(f), DetectionParams{});
    CAPTURE(seed, to_string(d.status), d.message, d.ambiguity_reason, d.interior_seams.seen_share());
    CHECK_FALSE((d.status == DetectionStatus::kOk && !d.ambiguous));
    CHECK(d.status == DetectionStatus::kSlipSheet);
    CHECK(d.boxes.empty());
  }
}

namespace {

/// The frame with a square patch `side_m` across without depth (a shiny label, a glint) in the
/// middle of the layer `d` found.
Frame with_patch(Frame frame, const Detection& d, double side_m) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2f& p : d.layer.points_2d) mean += p.cast<double>();
  mean /= static_cast<double>(d.layer.points_2d.size());
  const Eigen::Vector3d c = d.layer.T_camera_layer * Eigen::Vector3d(mean.x(), mean.y(), 0.0);
  const Intrinsics& in = frame.intrinsics;
  const auto u0 = static_cast<int>(in.fx * c.x() / c.z() + in.cx);
  const auto v0 = static_cast<int>(in.fy * c.y() / c.z() + in.cy);
  const int r = static_cast<int>(0.5 * side_m * in.fx / c.z()) + 1;
  for (int v = v0 - r; v < v0 + r; ++v)
    for (int u = u0 - r; u < u0 + r; ++u)
      frame.depth[static_cast<std::size_t>(v) * static_cast<std::size_t>(in.width) +
                  static_cast<std::size_t>(u)] = 0;
  return frame;
}

}  // namespace

TEST_CASE("a sheet with a hole where the depth drops out is flagged, never an unflagged layout", "[cell][sheet]") {
  // helios2 shows narrow seams (the whole sheet is named), o3d303 at 8-9 mm per pixel does not.
  for (const char* profile : {"helios2", "o3d303"}) {
    const sim::SimulatedFrame f = render_family(sim::SceneFamily::kSlipSheet, profile, 5);
    const Detection whole = detect(f.frame, formats_of(f), DetectionParams{});
    CAPTURE(profile, to_string(whole.status), whole.message, whole.ambiguity_reason);
    REQUIRE_FALSE((whole.status == DetectionStatus::kOk && !whole.ambiguous));
    // A patch 70 mm across: as wide as the chimney a pinwheel of cartons leaves.
    const Detection d = detect(with_patch(f.frame, whole, 0.07), formats_of(f), DetectionParams{});
    CAPTURE(to_string(d.status), d.message, d.ambiguity_reason, d.layer.polygons.size(), d.boxes.size(),
            d.interior_seams.seen_share(), d.interior_seams.length_m, whole.interior_seams.seen_share());
    REQUIRE(d.layer.polygons.size() == 1);
    CHECK(d.layer.polygons.front().holes.size() == 1);  // the patch is a hole in the layer
    CHECK_FALSE((d.status == DetectionStatus::kOk && !d.ambiguous));
    REQUIRE(d.status == DetectionStatus::kOk);  // a hole: no longer the plain rectangle a sheet is named by
    const bool fine_pitch = std::string(profile) == "helios2";
    CHECK_THAT(d.ambiguity_reason,
               Catch::Contains(fine_pitch ? "a slip sheet cannot be ruled out"
                                          : "a slip sheet and tightly packed cartons look the same"));
  }
}

TEST_CASE("a sheet with a dropout smaller than any chimney is still named a sheet", "[cell][sheet]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kSlipSheet, "helios2", 5);
  const Detection whole = detect(f.frame, formats_of(f), DetectionParams{});
  REQUIRE(whole.status == DetectionStatus::kSlipSheet);
  // 30 mm across: a hole in the layer (about 10 x 10 pixels), no place for a carton.
  const Detection d = detect(with_patch(f.frame, whole, 0.03), formats_of(f), DetectionParams{});
  CAPTURE(to_string(d.status), d.message, d.ambiguity_reason, d.boxes.size());
  REQUIRE(d.layer.polygons.size() == 1);
  CHECK(d.layer.polygons.front().holes.size() == 1);
  CHECK(d.status == DetectionStatus::kSlipSheet);
  CHECK(d.boxes.empty());
}

TEST_CASE("one box or two of another format: flagged where the camera cannot show the seam between",
          "[cell][formats]") {
  LayoutResult layout;
  layout.status = DetectionStatus::kOk;
  LayoutBox box;
  box.evidence.split_seam = 0.1;  // two boxes of another format would meet here: no seam seen
  layout.boxes = {box};
  layout.pixel_pitch_m = 0.004;
  layout.rim_share = 0.05;  // no mixed pixels at edges: a stereo camera
  const std::optional<LevelVerdict> stereo = formats_undecided(layout);
  REQUIRE(stereo);
  CHECK(stereo->status == DetectionStatus::kOk);
  CHECK(stereo->message.find("another recipe format") != std::string::npos);
  CHECK(stereo->message.find("stereo") != std::string::npos);
  layout.pixel_pitch_m = 0.015;  // a coarse time-of-flight camera
  layout.rim_share = 0.6;
  REQUIRE(formats_undecided(layout));
  CHECK(formats_undecided(layout)->message.find("pixel pitch of 15 mm") != std::string::npos);
  layout.pixel_pitch_m = 0.004;  // a fine one: no seam seen means there is none
  CHECK_FALSE(formats_undecided(layout));
  layout.rim_share = 0.05;
  layout.boxes[0].evidence.split_seam = 0.8;  // the seam is seen: the frame decides
  CHECK_FALSE(formats_undecided(layout));
  layout.boxes[0].evidence.split_seam = -1.0;  // no other format could stand here
  CHECK_FALSE(formats_undecided(layout));
}

TEST_CASE("two boxes that make another format meet without a seam: flagged on any camera",
          "[cell][formats]") {
  LayoutResult layout;
  layout.status = DetectionStatus::kOk;
  LayoutBox box;
  box.evidence.join_seam = 0.1;  // it and a neighbour make one box of another format: no seam between
  layout.boxes = {box, box};
  layout.pixel_pitch_m = 0.004;  // a fine time-of-flight camera: no seam seen means there is none
  layout.rim_share = 0.6;
  const std::optional<LevelVerdict> fine = formats_undecided(layout);
  REQUIRE(fine);
  CHECK(fine->status == DetectionStatus::kOk);
  CHECK_THAT(fine->message, Catch::StartsWith("2 box(es) meet a box of their format"));
  layout.rim_share = 0.05;  // a stereo camera: nothing decides
  REQUIRE(formats_undecided(layout));
  CHECK_THAT(formats_undecided(layout)->message, Catch::Contains("another recipe format"));
  layout.rim_share = 0.6;
  for (LayoutBox& b : layout.boxes) b.evidence.join_seam = 0.3;  // a faint trace of a pressed seam
  CHECK_FALSE(formats_undecided(layout));
  for (LayoutBox& b : layout.boxes) b.evidence.join_seam = 0.8;  // the seam between them is seen
  CHECK_FALSE(formats_undecided(layout));
}

TEST_CASE("the full layer a sheet would cover shows its seams", "[cell][sheet]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "helios2", 5);
  const Detection d = detect(f.frame, formats_of(f), DetectionParams{});
  CAPTURE(d.message, d.interior_seams.seen_share());
  REQUIRE(d.status == DetectionStatus::kOk);
  CHECK(d.interior_seams.length_m > 0.0);
  CHECK(d.interior_seams.seen_share() > 0.5);
}

TEST_CASE("a stepped pallet: only the cartons on top", "[cell][stepped]") {
  for (const std::uint64_t seed : {12u, 14u}) {
    const sim::SimulatedFrame f = render_family(sim::SceneFamily::kStepped, "o3d303", seed);
    REQUIRE_FALSE(f.truth.boxes.empty());
    const Detection d = detect(f.frame, formats_of(f), DetectionParams{});
    CAPTURE(seed, d.message, f.scene.description);
    REQUIRE(d.status == DetectionStatus::kOk);
    CHECK(d.boxes.size() == f.truth.boxes.size());
  }
}

namespace {

sim::SimBox carton(const Eigen::Vector2d& center_m, double long_m, double short_m, double bottom_m,
                   double top_m, int format_index, const std::string& name) {
  sim::SimBox b;
  b.center = center_m;
  b.long_m = long_m;
  b.short_m = short_m;
  b.bottom_z_m = bottom_m;
  b.top_z_m = top_m;
  b.bevel_m = 0.004;
  b.bulge_m = 0.002;
  b.reflectance = 0.5;
  b.format_index = format_index;
  b.format = name;
  return b;
}


}  // namespace

TEST_CASE("a real cell: one carton on a level of six, a cabinet above the load, a tilted stereo camera",
          "[cell][stepped]") {
  // The bare pallet, then two levels of 265 x 170 x 100 cartons (4 x 4, then 3 x 2), one
  // 354 x 271 carton on top, and a cabinet beside the pallet 0.45 m higher than the load.
  const sim::SensorProfile profile = *sim::profile_by_name("d435");
  sim::ScenarioOptions options;
  options.scene = sim::SceneFamily::kEmpty;
  sim::Scene scene = *sim::make_scene(options, profile, 17);
  const double deck_m = kPalletTop_m;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      scene.boxes.push_back(
          carton({-0.4 + 0.267 * i, -0.26 + 0.172 * j}, 0.265, 0.170, deck_m, deck_m + 0.1, 1, "265x170"));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j)
      scene.boxes.push_back(carton({-0.27 + 0.267 * i, -0.09 + 0.172 * j}, 0.265, 0.170, deck_m + 0.1,
                                   deck_m + 0.2, 1, "265x170"));
  const Eigen::Vector2d top_centre(-0.1, 0.0);
  scene.boxes.push_back(carton(top_centre, 0.354, 0.271, deck_m + 0.2, deck_m + 0.3, 0, "354x271"));
  scene.top_layer = {scene.boxes.size() - 1};
  scene.top_z_m = deck_m + 0.3;
  scene.expect = "boxes";
  sim::SimBox cabinet = carton({0.1, 0.75}, 0.8, 0.5, 0.0, scene.top_z_m + 0.45, -1, "");
  scene.boxes.push_back(cabinet);
  scene.recipe = {{"354x271", 0.354, 0.271, 0.1}, {"265x170", 0.265, 0.170, 0.1}};
  // 1.5 m above the load, tilted 6 deg (towards the cabinet, which fills the image's far part).
  scene.T_world_camera =
      sim::camera_looking_at(Eigen::Vector3d(0.0, -0.16, scene.top_z_m + 1.5), Eigen::Vector3d(0.0, 0.0, scene.top_z_m));
  const sim::SimulatedFrame f = sim::render(scene, profile, 17);
  REQUIRE(f.truth.boxes.size() == 1);
  const std::vector<BoxFormat> formats = {{0.354, 0.271, "354x271"}, {0.265, 0.170, "265x170"}};

  DetectionParams params;
  const Detection whole_view = detect(f.frame, formats, params);
  CAPTURE(to_string(whole_view.status), whole_view.message);
  CHECK_FALSE((whole_view.status == DetectionStatus::kOk && !whole_view.ambiguous &&
               whole_view.boxes.size() == 1));  // the cabinet's top is the highest level in view

  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kBase;
  roi.min_m = Eigen::Vector3d(-0.7, -0.5, deck_m - 0.05);
  roi.max_m = Eigen::Vector3d(0.7, 0.5, scene.top_z_m + 0.3);
  params.roi = roi;
  const Detection d = detect(f.frame, formats, params);
  CAPTURE(to_string(d.status), d.message, d.ambiguity_reason);
  REQUIRE(d.status == DetectionStatus::kOk);
  REQUIRE(d.boxes.size() == 1);
  CHECK(d.boxes[0].format == 0);
  CHECK((d.boxes[0].center - f.truth.boxes[0].center).norm() < 0.015);
  REQUIRE(d.boxes[0].base_position);
  CHECK((d.boxes[0].base_position->head<2>() - top_centre).norm() < 0.015);

  // Uncalibrated: the same volume as a camera-frame region; planes facing the camera, and the
  // higher-level search still finds the single carton above the level of six.
  Frame uncalibrated = f.frame;
  uncalibrated.T_base_camera.reset();
  const Eigen::Isometry3d T_camera_base = f.frame.T_base_camera->inverse();
  RegionOfInterest in_camera;
  in_camera.frame = RegionOfInterest::Frame::kCamera;
  in_camera.min_m = Eigen::Vector3d::Constant(1e9);
  in_camera.max_m = Eigen::Vector3d::Constant(-1e9);
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d q((corner & 1) != 0 ? roi.max_m.x() : roi.min_m.x(),
                            (corner & 2) != 0 ? roi.max_m.y() : roi.min_m.y(),
                            (corner & 4) != 0 ? roi.max_m.z() : roi.min_m.z());
    in_camera.min_m = in_camera.min_m.cwiseMin(T_camera_base * q);
    in_camera.max_m = in_camera.max_m.cwiseMax(T_camera_base * q);
  }
  params.roi = in_camera;
  const Detection u = detect(uncalibrated, formats, params);
  CAPTURE(to_string(u.status), u.message);
  REQUIRE(u.status == DetectionStatus::kOk);
  REQUIRE(u.boxes.size() == 1);
  CHECK(u.boxes[0].format == 0);
  CHECK((u.boxes[0].center - f.truth.boxes[0].center).norm() < 0.015);
}

TEST_CASE("cartons built over their format: the format found, the measured size reported",
          "[cell][oversize]") {
  const sim::SensorProfile profile = *sim::profile_by_name("o3d303");
  sim::ScenarioOptions options;
  options.pattern = sim::PatternFamily::kBlock;
  options.formats = {*sim::parse_format("400x300x250")};
  options.oversize_max = 0.05;
  options.gap_max_m = 0.002;  // pressed together: the seams barely show
  options.tilt_max_deg = 10.0;
  const sim::SimulatedFrame f = sim::render(*sim::make_scene(options, profile, 23), profile, 23);
  REQUIRE(f.truth.boxes.size() >= 4);
  const double built_long_m = f.truth.boxes[0].long_m;
  REQUIRE(built_long_m > 0.404);  // at least 1 % over
  const std::vector<BoxFormat> formats = {{0.4, 0.3, "400x300"}};

  auto worst_error_m = [&](const Detection& d) {
    double worst = 0.0;
    for (const TruthBox& t : f.truth.boxes) {
      double nearest = 1e9;
      for (const DetectedBox& b : d.boxes) nearest = std::min(nearest, (b.center - t.center).norm());
      worst = std::max(worst, nearest);
    }
    return worst;
  };
  const Detection d = detect(f.frame, formats, DetectionParams{});
  CAPTURE(to_string(d.status), d.message, built_long_m);
  REQUIRE(d.status == DetectionStatus::kOk);
  REQUIRE(d.boxes.size() == f.truth.boxes.size());
  CHECK(worst_error_m(d) < 0.015);
  for (const DetectedBox& b : d.boxes) CHECK(std::abs(b.long_m - built_long_m) < 0.006);

  // Held at nominal +- 5 mm, the same layer is placed worse.
  DetectionParams nominal;
  nominal.layout.refine.max_oversize = 0.0;
  const Detection held = detect(f.frame, formats, nominal);
  CHECK(worst_error_m(held) > worst_error_m(d));
}

TEST_CASE("a format a layer would hold thousands of is refused before the layout, in bounded time",
          "[cell][formats]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "o3d303", 7);
  std::vector<BoxFormat> formats = formats_of(f);
  formats.push_back({0.010, 0.005, "10x5 (mm entered as cm)"});  // found by fuzz_detection: seconds of layout
  const Detection d = detect(f.frame, formats, DetectionParams{});
  CHECK(d.status == DetectionStatus::kNoLayout);
  CHECK(d.message.find("more than 600 boxes") != std::string::npos);
  CHECK(d.boxes.empty());
  CHECK(d.timing_ms.count("layout") == 0);  // the search never started
}

namespace {

PolygonWithHoles strip(double x0_m, double width_m, double length_m) {
  PolygonWithHoles p;
  p.outer = {{x0_m, 0.0}, {x0_m + width_m, 0.0}, {x0_m + width_m, length_m}, {x0_m, length_m}};
  return p;
}

}  // namespace

// A EUR pallet's deck seen from above: boards 145 and 100 mm wide, 40 mm apart, 1200 mm long.
// A camera that smooths edges (stereo) may merge two boards and their gap into one strip 285 mm
// wide, which three 400 x 300 cartons would fill end to end.
TEST_CASE("deck boards are an empty pallet, also with two boards merged into one strip", "[cell][empty]") {
  const std::vector<BoxFormat> formats{{0.6, 0.4, "600x400"}, {0.4, 0.3, "400x300"}};
  const Frame frame;
  LayerResult deck;
  deck.polygons = {strip(0.0, 0.145, 1.2), strip(0.185, 0.1, 1.2), strip(0.325, 0.145, 1.2),
                   strip(0.51, 0.1, 1.2), strip(0.65, 0.145, 1.2)};
  const std::optional<LevelVerdict> boards = empty_level(frame, deck, formats, DetectionParams{});
  REQUIRE(boards);
  CHECK(boards->status == DetectionStatus::kEmpty);
  CHECK_THAT(boards->message, Catch::Contains("5 parallel strips"));

  LayerResult merged = deck;
  merged.polygons.erase(merged.polygons.begin(), merged.polygons.begin() + 2);
  merged.polygons.push_back(strip(-0.3, 0.285, 1.19));
  CHECK(empty_level(frame, merged, formats, DetectionParams{}));

  LayerResult row = merged;  // a strip as wide but shorter than the boards: a row of cartons
  row.polygons.back() = strip(-0.3, 0.285, 0.8);
  CHECK_FALSE(empty_level(frame, row, formats, DetectionParams{}));
  LayerResult wide = merged;  // wider than two boards: a carton's top
  wide.polygons.back() = strip(-0.5, 0.41, 1.2);
  CHECK_FALSE(empty_level(frame, wide, formats, DetectionParams{}));
  LayerResult two_boards = merged;  // two narrow strips beside a merged one: not enough boards
  two_boards.polygons.erase(two_boards.polygons.begin());
  CHECK_FALSE(empty_level(frame, two_boards, formats, DetectionParams{}));
}

TEST_CASE("a seamless rectangle is a sheet unless half its boxes show tape along their middles",
          "[cell][sheet]") {
  // Six 400 x 300 cartons pressed together in a 1200 x 600 rectangle, no seam seen between them,
  // on a camera that shows narrow seams. A sheet is plain; cartons carry tape along their flaps.
  LayoutResult layout;
  layout.status = DetectionStatus::kOk;
  layout.boxes.resize(6);
  layout.pixel_pitch_m = 0.004;
  layout.rim_share = 0.6;
  layout.interior_seams.length_m = 2.0;
  layout.interior_seams.seen_m = 0.05;
  LayerResult layer;
  layer.polygons.push_back(PolygonWithHoles{{{0.0, 0.0}, {1.2, 0.0}, {1.2, 0.6}, {0.0, 0.6}}, {}});
  const std::vector<BoxFormat> formats = {BoxFormat{0.4, 0.3, "400x300", 0.0}};
  const std::optional<LevelVerdict> plain = slip_sheet(layout, layer, formats);
  REQUIRE(plain);
  CHECK(plain->status == DetectionStatus::kSlipSheet);
  layout.interior_seams.taped_boxes = 2;  // two of six: a print or a label may line up by chance
  REQUIRE(slip_sheet(layout, layer, formats));
  CHECK(slip_sheet(layout, layer, formats)->status == DetectionStatus::kSlipSheet);
  layout.interior_seams.taped_boxes = 3;
  CHECK_FALSE(slip_sheet(layout, layer, formats));
  layout.rim_share = 0.05;  // a stereo camera: without tape in doubt, with it cartons
  CHECK_FALSE(slip_sheet(layout, layer, formats));
  layout.interior_seams.taped_boxes = 0;
  REQUIRE(slip_sheet(layout, layer, formats));
  CHECK(slip_sheet(layout, layer, formats)->status == DetectionStatus::kOk);
}
