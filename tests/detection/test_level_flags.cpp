// The flags level_checks.hpp raises on a camera that does not show narrow seams (a coarse pixel
// pitch, or no mixed pixels at edges: stereo, structured light): a layout that mixes formats, a
// search that ended on its budget. Where the camera shows seams, the seams decide and neither flags
// (unless the seams of a mix do not show where its boxes meet), and a seam across a box's top
// flags; on every camera: boxes placed less surely than the limit, a layer turned less surely,
// boxes measured shorter than their format, boxes that reach into each other, pieces of the layer
// without boxes, boxes the depth sees through, boxes completed where the depth ends and turned.
#include <catch2/catch.hpp>

#include "palletd/detection/layout.hpp"

#include "level_checks.hpp"

using namespace palletd;

namespace {

LayoutBox box_of(int format, double x_m) {
  LayoutBox b;
  b.center = Eigen::Vector2d(x_m, 0.0);
  b.long_m = format == 0 ? 0.4 : 0.3;
  b.short_m = format == 0 ? 0.3 : 0.2;
  b.format = format;
  return b;
}

/// A layout seen at `pitch_m` per pixel with mixed pixels along `rim_share` of its outline.
LayoutResult layout_seen(double pitch_m, double rim_share, std::vector<int> formats) {
  LayoutResult layout;
  layout.status = DetectionStatus::kOk;
  layout.pixel_pitch_m = pitch_m;
  layout.rim_share = rim_share;
  double x_m = 0.0;
  for (const int f : formats) {
    layout.boxes.push_back(box_of(f, x_m));
    x_m += 0.4;
  }
  return layout;
}

}  // namespace

TEST_CASE("a mix of formats on a camera that does not show narrow seams is flagged", "[cell][flags]") {
  const LayoutResult stereo = layout_seen(0.004, 0.1, {0, 1, 0});  // no mixed pixels at edges
  const std::optional<LevelVerdict> v = mix_by_outline(stereo);
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::Contains("mixes 2 formats"));
  CHECK_THAT(v->message, Catch::Contains("no mixed pixels"));
  const std::optional<LevelVerdict> coarse = mix_by_outline(layout_seen(0.009, 0.8, {0, 1}));
  REQUIRE(coarse);
  CHECK_THAT(coarse->message, Catch::Contains("cannot be resolved"));
  // One format: nothing to mix up. A time-of-flight camera at a fine pitch: the seams decide.
  CHECK_FALSE(mix_by_outline(layout_seen(0.004, 0.1, {1, 1, 1})));
  CHECK_FALSE(mix_by_outline(layout_seen(0.004, 0.8, {0, 1, 0})));
}

TEST_CASE("a mix of formats whose seams do not show where its boxes meet is flagged on any camera",
          "[cell][flags]") {
  LayoutResult pressed = layout_seen(0.004, 0.8, {0, 1, 0});  // a camera that shows seams
  pressed.interior_seams.length_m = 1.2;
  pressed.interior_seams.seen_m = 0.12;  // the cartons are pressed together
  const std::optional<LevelVerdict> v = mix_by_outline(pressed);
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::Contains("mixes 2 formats"));
  CHECK_THAT(v->message, Catch::Contains("seams show along only 0.1 of the sides"));
  pressed.interior_seams.seen_m = 0.6;  // half of them show: the seams decide
  CHECK_FALSE(mix_by_outline(pressed));
  LayoutResult one_format = layout_seen(0.004, 0.8, {1, 1, 1});
  one_format.interior_seams.length_m = 1.2;
  CHECK_FALSE(mix_by_outline(one_format));  // nothing to mix up, seams or not
}

TEST_CASE("a box completed where the depth ends and turned against the boxes seen whole is flagged",
          "[cell][flags]") {
  LayoutResult layout = layout_seen(0.004, 0.8, {0, 0, 0});
  for (LayoutBox& b : layout.boxes) b.yaw_rad = 0.1;
  layout.boxes[2].partly_unseen = true;
  layout.boxes[2].yaw_rad = 0.1 + 0.5 * M_PI + 0.02;  // a quarter turn and a degree: square to them
  CHECK_FALSE(turned_unseen_boxes(layout));
  layout.boxes[2].yaw_rad = 0.1 - 0.28;  // 16 degrees
  const std::optional<LevelVerdict> v = turned_unseen_boxes(layout);
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message,
             Catch::Contains("1 box(es) completed where the depth ends stand turned by up to 16 degrees"));
  layout.boxes[2].partly_unseen = false;  // seen whole: a turned carton, its sides tell
  CHECK_FALSE(turned_unseen_boxes(layout));
  for (LayoutBox& b : layout.boxes) b.partly_unseen = true;  // none seen whole: nothing to compare with
  CHECK_FALSE(turned_unseen_boxes(layout));
}

TEST_CASE("a search that ended on its budget is flagged where only the outline decides", "[cell][flags]") {
  LayoutResult stereo = layout_seen(0.004, 0.1, {0, 0, 0});
  CHECK_FALSE(search_unfinished(stereo));  // finished
  stereo.budget_exhausted = true;
  const std::optional<LevelVerdict> v = search_unfinished(stereo);
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::Contains("ended on its budget"));
  LayoutResult tof = layout_seen(0.004, 0.8, {0, 0, 0});
  tof.budget_exhausted = true;
  CHECK_FALSE(search_unfinished(tof));
}

namespace {

RefineParams position_limits(double max_mm, double max_px) {
  RefineParams refine;
  refine.max_position_sigma_mm = max_mm;
  refine.max_position_sigma_px = max_px;
  return refine;
}

}  // namespace

TEST_CASE("a box placed less surely than the limit flags the layout, whatever the camera", "[cell][flags]") {
  LayoutResult layout = layout_seen(0.008, 0.8, {0, 0, 0});  // two pitches: 16 mm
  layout.boxes[0].evidence.position_sigma_m = 0.004;
  layout.boxes[1].evidence.position_sigma_m = 0.012;
  layout.boxes[2].evidence.position_sigma_m = -1.0;  // not refined: nothing to judge
  const std::optional<LevelVerdict> v = uncertain_positions(layout, position_limits(10.0, 1.0));
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::StartsWith("1 box(es)") && Catch::Contains("up to 12 mm"));
  CHECK_FALSE(uncertain_positions(layout, position_limits(20.0, 1.0)));
  CHECK_FALSE(uncertain_positions(layout, position_limits(0.0, 1.0)));  // 0: never
  CHECK(RefineParams{}.max_position_sigma_mm > 0.0);                    // on by default
  CHECK(uncertain_positions(layout, RefineParams{}));
  layout.boxes[1].evidence.position_sigma_m = 0.009;
  CHECK_FALSE(uncertain_positions(layout, position_limits(10.0, 1.0)));
}

TEST_CASE("a layer whose turn is measured less surely than the limit flags the layout", "[cell][flags]") {
  LayoutResult layout = layout_seen(0.0175, 0.6, {1});
  layout.boxes[0].evidence.yaw_sigma_rad = 1.6 * M_PI / 180.0;
  const std::optional<LevelVerdict> v = uncertain_turn(layout, RefineParams{});
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::Contains("measured to 1.6 degrees") && Catch::Contains("pitch of 18 mm"));
  RefineParams never;
  never.max_yaw_sigma_deg = 0.0;
  CHECK_FALSE(uncertain_turn(layout, never));
  layout.boxes[0].evidence.yaw_sigma_rad = 1.0 * M_PI / 180.0;
  CHECK_FALSE(uncertain_turn(layout, RefineParams{}));
  layout.boxes[0].evidence.yaw_sigma_rad = -1.0;  // not refined: nothing to judge
  CHECK_FALSE(uncertain_turn(layout, RefineParams{}));
}

TEST_CASE("a box placed worse than two pixel pitches flags the layout, whatever the millimetre limit",
          "[cell][flags]") {
  // 4.2 mm per pixel: two pitches are 8.4 mm, under the 10 mm limit.
  LayoutResult fine = layout_seen(0.0042, 0.8, {0, 0, 0});
  fine.boxes[1].evidence.position_sigma_m = 0.0092;
  const std::optional<LevelVerdict> v = uncertain_positions(fine, RefineParams{});
  REQUIRE(v);
  CHECK_THAT(v->message, Catch::Contains("less surely than 8 mm"));
  CHECK(uncertain_positions(fine, position_limits(20.0, 1.0)));  // a looser limit in mm does not hide it
  fine.boxes[1].evidence.position_sigma_m = 0.0075;
  CHECK_FALSE(uncertain_positions(fine, RefineParams{}));
  // At 2 mm per pixel the limit stays at 5 mm.
  LayoutResult finer = layout_seen(0.002, 0.8, {0, 0, 0});
  finer.boxes[1].evidence.position_sigma_m = 0.0045;
  CHECK_FALSE(uncertain_positions(finer, RefineParams{}));
  finer.boxes[1].evidence.position_sigma_m = 0.006;
  CHECK(uncertain_positions(finer, RefineParams{}));
}

TEST_CASE(
    "the position limit grows with the pixel pitch where configured: a coarse camera places a side to a "
    "pixel",
    "[cell][flags]") {
  // 16 mm per pixel: 2 pitches are 32 mm, so 19 mm is as well as this camera places a side.
  LayoutResult coarse = layout_seen(0.016, 0.8, {0, 0, 0});
  coarse.boxes[1].evidence.position_sigma_m = 0.019;
  CHECK_FALSE(uncertain_positions(coarse, position_limits(10.0, 2.0)));
  CHECK(uncertain_positions(coarse, position_limits(10.0, 0.0)));  // the millimetres alone
  coarse.boxes[1].evidence.position_sigma_m = 0.040;
  const std::optional<LevelVerdict> v = uncertain_positions(coarse, position_limits(10.0, 2.0));
  REQUIRE(v);
  CHECK_THAT(v->message, Catch::Contains("less surely than 32 mm") && Catch::Contains("pitch of 16 mm"));
  // One pitch: a box placed to 15 mm passes on this camera, one worse than a pixel does not.
  coarse.boxes[1].evidence.position_sigma_m = 0.015;
  CHECK_FALSE(uncertain_positions(coarse, position_limits(10.0, 1.0)));
  coarse.boxes[1].evidence.position_sigma_m = 0.019;
  CHECK_THAT(uncertain_positions(coarse, position_limits(10.0, 1.0))->message,
             Catch::Contains("less surely than 16 mm"));
  // By default the millimetres hold whatever the camera: a gripper's tolerance does not grow
  // with its pixels (a box placed to 11 mm at 15 mm per pixel came out 16.5 mm off).
  coarse.boxes[1].evidence.position_sigma_m = 0.011;
  const std::optional<LevelVerdict> by_default = uncertain_positions(coarse, RefineParams{});
  REQUIRE(by_default);
  CHECK_THAT(by_default->message, Catch::Contains("less surely than 10 mm"));
  coarse.boxes[1].evidence.position_sigma_m = 0.009;
  CHECK_FALSE(uncertain_positions(coarse, RefineParams{}));
}

TEST_CASE("a box whose fit was rejected flags the layout: its place is the search's, unconfirmed",
          "[cell][flags]") {
  LayoutResult layout = layout_seen(0.004, 0.8, {0, 0, 0});
  for (LayoutBox& b : layout.boxes) b.evidence.position_sigma_m = 0.002;
  CHECK_FALSE(uncertain_positions(layout, RefineParams{}));
  layout.boxes[2].evidence.position_sigma_m = -1.0;
  layout.boxes[2].evidence.fit_rejected = true;
  const std::optional<LevelVerdict> v = uncertain_positions(layout, RefineParams{});
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::StartsWith("1 box(es) the sides seen around them would move"));
  CHECK_FALSE(uncertain_positions(layout, position_limits(0.0, 1.0)));  // 0: never
  layout.boxes[0].evidence.position_sigma_m = 0.019;                    // both reasons, one verdict
  const std::optional<LevelVerdict> both = uncertain_positions(layout, RefineParams{});
  REQUIRE(both);
  CHECK_THAT(both->message,
             Catch::StartsWith("1 box(es) placed less surely") && Catch::Contains("; 1 box(es) the sides"));
}

TEST_CASE("a search that ended on its budget with a mix of formats is flagged on any camera",
          "[cell][flags]") {
  LayoutResult tof = layout_seen(0.004, 0.8, {0, 1, 1});
  CHECK_FALSE(search_unfinished(tof));  // finished: the seams weighed every mix
  tof.budget_exhausted = true;
  const std::optional<LevelVerdict> v = search_unfinished(tof);
  REQUIRE(v);
  CHECK_THAT(v->message, Catch::Contains("mixes 2 of them"));
}

TEST_CASE("a box its own sides measure shorter than its format flags the layout, a larger one does not",
          "[cell][flags]") {
  const std::vector<BoxFormat> formats = {{0.4, 0.3, "400x300"}, {0.3, 0.2, "300x200"}};
  LayoutResult layout = layout_seen(0.004, 0.8, {0, 0, 1});
  layout.boxes[0].evidence.measured_long_m = 0.412;  // built 3 % over: a real carton
  layout.boxes[0].evidence.measured_short_m = 0.309;
  layout.boxes[1].evidence.measured_long_m = 0.393;  // 7 mm short: within the size tolerance
  layout.boxes[2].evidence.measured_short_m = -1.0;  // not measured
  CHECK_FALSE(undersized_boxes(layout, formats, RefineParams{}));
  layout.boxes[1].evidence.measured_long_m = 0.381;  // 19 mm short: not a 400 x 300
  const std::optional<LevelVerdict> v = undersized_boxes(layout, formats, RefineParams{});
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::StartsWith("1 box(es)") && Catch::Contains("19 mm shorter") &&
                             Catch::Contains("more than 10 mm"));
  // At 15 mm per pixel a side is placed to about a pixel: 19 mm is within two pitches.
  layout.pixel_pitch_m = 0.015;
  CHECK_FALSE(undersized_boxes(layout, formats, RefineParams{}));
}

TEST_CASE("boxes that reach into each other deeper than the size tolerance flag the layout",
          "[cell][flags]") {
  // Three 400 x 300 boxes side by side along x, touching: cartons, not a crowd.
  LayoutResult layout = layout_seen(0.004, 0.8, {0, 0, 0});
  CHECK_FALSE(overlapping_boxes(layout, RefineParams{}));
  layout.boxes[1].center.x() -= 0.008;  // 8 mm into box 0: a bulge, within the tolerance
  CHECK_FALSE(overlapping_boxes(layout, RefineParams{}));
  layout.boxes[2].center.x() -= 0.023;  // 15 mm into box 1
  const std::optional<LevelVerdict> v = overlapping_boxes(layout, RefineParams{});
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::StartsWith("boxes 1 and 2 overlap by 15 mm"));
  RefineParams loose;
  loose.size_tolerance_m = 0.02;
  CHECK_FALSE(overlapping_boxes(layout, loose));
  layout.boxes[2].yaw_rad = 0.3;  // turned: how deep the corners reach, not how far the centres are
  CHECK(overlapping_boxes(layout, RefineParams{}));
}

TEST_CASE("a piece of the layer as large as half a box that holds no box flags the layout", "[cell][flags]") {
  auto rect = [](double x0, double y0, double x1, double y1) {
    PolygonWithHoles p;
    p.outer = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
    return p;
  };
  const std::vector<BoxFormat> formats{{0.4, 0.3, "400x300"}};
  LayerResult layer;
  layer.polygons = {rect(-0.2, -0.15, 1.0, 0.15), rect(1.1, -0.6, 1.25, 0.6)};  // boxes; a strip 150 x 1200
  LayoutResult layout = layout_seen(0.005, 0.8, {0, 0, 0});
  const std::optional<LevelVerdict> v = pieces_without_boxes(layout, layer, formats);
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::Contains("1 piece(s) of the layer hold no box (the largest 1.5 times"));
  // A box on the strip explains it; a speck under half a box's top is no piece.
  layout.boxes.back().component = 1;
  CHECK_FALSE(pieces_without_boxes(layout, layer, formats));
  layout.boxes.back().component = 0;
  layer.polygons.back() = rect(1.1, -0.1, 1.3, 0.1);  // 0.04 m2, a third of the box's 0.12
  CHECK_FALSE(pieces_without_boxes(layout, layer, formats));
}

namespace {

/// A camera 2 m above a level layer looking straight down (200 x 200 pixels, 10 mm per pixel on
/// the layer); pixels whose ray meets the layer inside `hole` (camera x, y) see `hole_depth_m`.
struct LookingDown {
  OrganizedCloud cloud;
  LayerResult layer;
};

LookingDown looking_down(const Eigen::AlignedBox2d& hole, double hole_depth_m) {
  LookingDown s;
  s.cloud.width = s.cloud.height = 200;
  for (int v = 0; v < 200; ++v) {
    for (int u = 0; u < 200; ++u) {
      const Eigen::Vector3d ray((u - 100) / 200.0, (v - 100) / 200.0, 1.0);
      const bool in_hole = hole.contains(Eigen::Vector2d(2.0 * ray.x(), 2.0 * ray.y()));
      s.cloud.points.push_back((ray * (in_hole ? hole_depth_m : 2.0)).cast<float>());
    }
  }
  s.layer.plane_camera.normal = Eigen::Vector3d(0.0, 0.0, -1.0);  // towards the camera
  s.layer.plane_camera.d = 2.0;
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d::UnitX();
  R.col(1) = -Eigen::Vector3d::UnitY();
  R.col(2) = -Eigen::Vector3d::UnitZ();
  s.layer.T_camera_layer.linear() = R;  // layer (x, y, 0) -> camera (x, -y, 2)
  s.layer.T_camera_layer.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
  return s;
}

LayoutResult one_box_at(double x_m) {
  LayoutResult layout = layout_seen(0.01, 0.8, {0});
  layout.boxes.front().center = Eigen::Vector2d(x_m, 0.0);
  return layout;
}

}  // namespace

TEST_CASE("a box the depth sees through to a level below flags the layout", "[cell][flags]") {
  // A hole 200 x 200 mm showing depth 0.3 m below the layer.
  const LookingDown s =
      looking_down(Eigen::AlignedBox2d(Eigen::Vector2d(0.1, -0.1), Eigen::Vector2d(0.3, 0.1)), 2.3);
  const std::optional<LevelVerdict> v = boxes_over_holes(s.cloud, one_box_at(0.2), s.layer);
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message, Catch::Contains("1 box(es) stand over a hole"));
  CHECK_FALSE(boxes_over_holes(s.cloud, one_box_at(-0.4), s.layer));  // the box beside the hole
  // A dip of 30 mm (a sagging top, a seam) is no hole.
  const LookingDown dip =
      looking_down(Eigen::AlignedBox2d(Eigen::Vector2d(0.1, -0.1), Eigen::Vector2d(0.3, 0.1)), 2.03);
  CHECK_FALSE(boxes_over_holes(dip.cloud, one_box_at(0.2), dip.layer));
}

TEST_CASE("depth seen past a box's side, under its overhang, is no hole in its top", "[cell][flags]") {
  // Rays that meet the layer 450-540 mm off the centre see a level 0.6 m lower: straight below a
  // box spanning 550-950 mm (585-700 mm at that depth), but past its side, where no top is.
  const LookingDown s =
      looking_down(Eigen::AlignedBox2d(Eigen::Vector2d(0.45, -0.1), Eigen::Vector2d(0.54, 0.1)), 2.6);
  CHECK_FALSE(boxes_over_holes(s.cloud, one_box_at(0.75), s.layer));
  CHECK(boxes_over_holes(s.cloud, one_box_at(0.45), s.layer));  // a box where the rays meet the layer
}

TEST_CASE("a seam line across a box's top flags the layout at a pitch that can show one", "[cell][flags]") {
  LayoutResult tof = layout_seen(0.005, 0.5, {0, 0, 0});  // 5 mm per pixel, mixed pixels at edges
  tof.boxes[1].evidence.interior_seam = 0.74;
  const std::optional<LevelVerdict> v = seams_across_boxes(tof);
  REQUIRE(v);
  CHECK(v->status == DetectionStatus::kOk);
  CHECK_THAT(v->message,
             Catch::Contains("1 box(es) have a seam line across their top (strength up to 0.74)"));
  tof.boxes[1].evidence.interior_seam = 0.3;  // a weak line: tape, print, noise
  CHECK_FALSE(seams_across_boxes(tof));
  // A stereo camera (no mixed pixels at edges) smooths narrow seams away, but one it shows across
  // a top is a seam: a mirrored pinwheel on a d435 at 6.6 mm per pixel showed 0.67.
  LayoutResult stereo = layout_seen(0.0066, 0.0, {0, 0, 0});
  stereo.boxes[1].evidence.interior_seam = 0.67;
  CHECK(seams_across_boxes(stereo));
  // At a pitch too coarse to draw a line across a top, a "line" is not read as one.
  LayoutResult coarse = layout_seen(0.015, 0.7, {0, 0, 0});
  coarse.boxes[1].evidence.interior_seam = 0.9;
  CHECK_FALSE(seams_across_boxes(coarse));
}
