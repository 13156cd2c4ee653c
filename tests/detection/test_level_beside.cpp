// lower_level_beside and the sheet it rules out: the next level of the load beside the top level,
// on a cloud laid out by hand (the camera 2 m above the top level, looking straight down).
#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"

#include "level_checks.hpp"

using namespace palletd;

namespace {

constexpr double kBesidePitch_m = 0.005;
constexpr double kBesideTop_m = 2.0;  ///< the top level's depth

/// Depth at a point of the view: the top level over [0, 1.2] x [0, 0.6], then what `beside`
/// gives (nothing: NaN).
template <typename Beside>
OrganizedCloud view(Beside beside) {
  OrganizedCloud cloud;
  cloud.width = 400;
  cloud.height = 320;
  for (int v = 0; v < cloud.height; ++v) {
    for (int u = 0; u < cloud.width; ++u) {
      const double x = -0.4 + u * kBesidePitch_m, y = -0.4 + v * kBesidePitch_m;
      const bool top = x >= 0.0 && x <= 1.2 && y >= 0.0 && y <= 0.6;
      const double z = top ? kBesideTop_m : beside(x, y);
      cloud.points.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    }
  }
  return cloud;
}

LayerResult top_level() {
  LayerResult layer;
  layer.polygons.push_back(PolygonWithHoles{{{0.0, 0.0}, {1.2, 0.0}, {1.2, 0.6}, {0.0, 0.6}}, {}});
  layer.T_camera_layer = Eigen::Translation3d(0.0, 0.0, kBesideTop_m) * Eigen::Isometry3d::Identity();
  return layer;
}

std::vector<BoxFormat> cartons_400x300() { return {BoxFormat{0.4, 0.3, "400x300", 0.0}}; }

}  // namespace

TEST_CASE("the next level beside the top is found, the floor and a narrow strip are not", "[cell][sheet]") {
  const LayerResult layer = top_level();
  const PlaneParams validity;
  const auto floor_at = [](double z_m) { return [z_m](double, double) { return z_m; }; };
  // A row picked off the top: the level under it, 250 mm lower, beside the rest of the layer.
  const OrganizedCloud picked = view([](double x, double y) {
    return x >= 0.0 && x <= 1.2 && y > 0.6 && y <= 1.0 ? kBesideTop_m + 0.25 : kBesideTop_m + 1.5;
  });
  const std::optional<LevelBeside> next =
      lower_level_beside(picked, layer, cartons_400x300(), validity, kBesidePitch_m);
  REQUIRE(next);
  CHECK(next->drop_m == Approx(0.25).margin(0.01));
  CHECK(next->area_m2 > 0.25);  // 1.2 m along the layer, from 60 mm out to 300 mm
  // A full layer: the floor 1.5 m down around it, or only 0.5 m down (a low stack).
  CHECK_FALSE(lower_level_beside(view(floor_at(kBesideTop_m + 1.5)), layer, cartons_400x300(), validity,
                                 kBesidePitch_m));
  CHECK_FALSE(lower_level_beside(view(floor_at(kBesideTop_m + 0.5)), layer, cartons_400x300(), validity,
                                 kBesidePitch_m));
  // A deck's edge 40 mm wide beside the layer: the stack's foot, no level.
  const OrganizedCloud deck_edge = view([](double x, double y) {
    return x >= 0.0 && x <= 1.2 && y > 0.6 && y <= 0.64 ? kBesideTop_m + 0.25 : kBesideTop_m + 1.5;
  });
  CHECK_FALSE(lower_level_beside(deck_edge, layer, cartons_400x300(), validity, kBesidePitch_m));
}

TEST_CASE("a level beside the top at the pallet's height is no level of the load", "[cell][sheet]") {
  // A roller conveyor at pallet height beside a full first layer 250 mm high.
  const OrganizedCloud conveyor = view([](double x, double y) {
    return x >= 0.0 && x <= 1.2 && y > 0.65 && y <= 1.0 ? kBesideTop_m + 0.25 : kBesideTop_m + 1.5;
  });
  const LayerResult layer = top_level();
  CHECK(lower_level_beside(conveyor, layer, cartons_400x300(), PlaneParams{}, kBesidePitch_m));
  CHECK_FALSE(lower_level_beside(conveyor, layer, cartons_400x300(), PlaneParams{}, kBesidePitch_m, 0.26));
  CHECK(lower_level_beside(conveyor, layer, cartons_400x300(), PlaneParams{}, kBesidePitch_m,
                           0.52));  // a layer lower
}

TEST_CASE("a seamless rectangle beside the load's next level is flagged, not named a sheet",
          "[cell][sheet]") {
  // Six 400 x 300 pressed together in a 1200 x 600 rectangle, no seam seen between them, on a
  // camera that shows narrow seams: slip_sheet() names it a sheet.
  LayoutResult layout;
  layout.status = DetectionStatus::kOk;
  layout.pixel_pitch_m = 0.004;
  layout.rim_share = 0.6;
  layout.interior_seams.length_m = 2.0;
  layout.interior_seams.seen_m = 0.05;
  for (int i = 0; i < 6; ++i) {
    LayoutBox& b = layout.boxes.emplace_back();
    const int row = i / 3, col = i % 3;
    b.center = Eigen::Vector2d(0.2 + 0.4 * col, 0.15 + 0.3 * row);
    b.long_m = 0.4;
    b.short_m = 0.3;
  }
  const LayerResult layer = top_level();
  REQUIRE(slip_sheet(layout, layer, cartons_400x300()));
  REQUIRE(slip_sheet(layout, layer, cartons_400x300())->status == DetectionStatus::kSlipSheet);
  const auto level = [&](const OrganizedCloud& cloud) {
    return level_after_layout(cloud, layout, layer, cartons_400x300(), PlaneParams{}, RefineParams{},
                              std::nullopt, std::nullopt);
  };
  const std::optional<LevelVerdict> full = level(view([](double, double) { return kBesideTop_m + 1.5; }));
  REQUIRE(full);
  CHECK(full->status == DetectionStatus::kSlipSheet);
  const std::optional<LevelVerdict> rest = level(view([](double x, double y) {
    return x >= 0.0 && x <= 1.2 && y > 0.6 && y <= 1.0 ? kBesideTop_m + 0.25 : kBesideTop_m + 1.5;
  }));
  REQUIRE(rest);
  CHECK(rest->status == DetectionStatus::kOk);
  CHECK_THAT(rest->message, Catch::Contains("next level shows beside the layer (250 mm lower"));
}
