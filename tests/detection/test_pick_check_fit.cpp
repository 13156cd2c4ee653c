// The check's internals (check_internal.hpp) on synthetic data: where a box's sides step down
// in a frame (edge_samples), and the move of a box from its sides' steps (fit_move): how far it
// moved and how well the samples say so.
#include <cmath>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#include "palletd/core/frame.hpp"

#include "pick_check/check_internal.hpp"

using namespace palletd;

namespace {

/// A sample on side 0 or 1 (normal +x or -x, 0.2 m out) or side 2 or 3 (normal +y or -y, 0.15 m
/// out), `along_m` along it, its step `offset_m` outward.
pick_check::EdgeSample side_sample(int side, double along_m, double offset_m) {
  pick_check::EdgeSample s;
  s.side = side;
  const double sign = side % 2 == 0 ? 1.0 : -1.0;
  s.normal_box = sign * (side < 2 ? Eigen::Vector2d::UnitX() : Eigen::Vector2d::UnitY());
  s.point_box = side < 2 ? Eigen::Vector2d(0.2 * sign, along_m) : Eigen::Vector2d(along_m, 0.15 * sign);
  s.offset_m = offset_m;
  return s;
}

/// What a camera 2 m straight above the layer sees (5 mm per pixel) where one side of a top
/// 0.3 x 0.2 m (the layer frame's x from -0.15 to 0.15 m) has a band of no depth `shadow_m` wide
/// beyond it, then `beyond`: the lower level 0.3 m down, or another box's top.
pick_check::Grid shadowed_side(double shadow_m, pick_check::Seen beyond) {
  Frame frame;
  frame.intrinsics = Intrinsics{200, 200, 400.0, 400.0, 99.5, 99.5, std::nullopt};
  frame.depth.assign(frame.pixel_count(), 0);
  const RayTable rays(frame.intrinsics);
  for (std::size_t i = 0; i < frame.pixel_count(); ++i) {
    const double x_m = 2.0 * rays.ray(i).x(), y_m = -2.0 * rays.ray(i).y();  // on the top's plane
    const bool on_top = std::abs(x_m) <= 0.15 && std::abs(y_m) <= 0.1;
    const bool in_shadow = x_m > 0.15 && x_m <= 0.15 + shadow_m && std::abs(y_m) <= 0.1;
    const bool top_beyond = beyond == pick_check::Seen::kTop && x_m > 0.15 + shadow_m;
    if (in_shadow) continue;
    frame.depth[i] = on_top || top_beyond ? 2000 : 2300;
  }
  // The layer frame: x right, y up the image, z toward the camera, its origin on the top.
  Eigen::Isometry3d T_layer_camera = Eigen::Isometry3d::Identity();
  T_layer_camera.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  T_layer_camera.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
  pick_check::Grid grid(Eigen::Vector2d(-0.6, -0.6), Eigen::Vector2d(0.6, 0.6), 0.005);
  grid.add_frame(frame, rays, T_layer_camera, pick_check::kBand_m, pick_check::kDrop_m);
  return grid;
}

/// The samples edge_samples() finds on each side of the top of shadowed_side().
std::vector<std::vector<double>> side_offsets(const pick_check::Grid& grid) {
  Box2d top;
  top.center = Eigen::Vector2d::Zero();
  top.long_m = 0.3;
  top.short_m = 0.2;
  std::vector<std::vector<double>> per_side(4);
  for (const auto& s : pick_check::edge_samples(grid, top, 0.06))
    if (s) per_side[static_cast<std::size_t>(s->side)].push_back(s->offset_m);
  return per_side;
}

}  // namespace

TEST_CASE("pick check: a side whose step a deep shadow hides past the reach still shows where the top ends",
          "[pick_check]") {
  // A pick leaves a hole one carton deep; a camera looking past a side into it sees no depth for
  // tens of millimetres beyond (the side's shadow), then the level below. A stereo camera showed
  // such a side of a dragged box as no step at all (bench seed 91041 frame 43: no side seen, a
  // 15 mm drag read as no move).
  const auto shadowed = side_offsets(shadowed_side(0.10, pick_check::Seen::kLower));
  REQUIRE(shadowed[0].size() >= 10);
  for (const double offset_m : shadowed[0]) CHECK(std::abs(offset_m) <= 0.006);
  for (std::size_t side = 1; side < 4; ++side) CHECK(shadowed[side].size() >= 10);
  // A top past the shadow is another box's: the side abuts it across a gap it does not show.
  const auto boxed = side_offsets(shadowed_side(0.10, pick_check::Seen::kTop));
  CHECK(boxed[0].empty());
  CHECK(boxed[1].size() >= 10);
  // Further than any shadow the check allows for: nothing is read from it.
  CHECK(side_offsets(shadowed_side(0.25, pick_check::Seen::kLower))[0].empty());
}

TEST_CASE("pick check: lines across a side that read the same pixel count once in the move's uncertainty",
          "[pick_check]") {
  // Two sides at a 20 mm pixel pitch, read by lines 10 mm apart: each pixel's step is read twice.
  const double pitch_m = 0.020;
  std::vector<pick_check::EdgeSample> once, twice;
  for (const int side : {0, 2}) {
    for (int j = -8; j <= 7; ++j) {
      const double step_m = 0.002 * std::sin(1.7 * j + side);  // the pixel's reading
      for (int line = 0; line < 2; ++line) {
        const pick_check::EdgeSample s =
            side_sample(side, pitch_m * j + pick_check::kSampleSpacing_m * line, step_m);
        twice.push_back(s);
        if (line == 0) once.push_back(s);
      }
    }
  }
  const pick_check::Move one_line = pick_check::fit_move(once, 0.0);
  const pick_check::Move two_lines = pick_check::fit_move(twice, pitch_m);
  for (int k = 0; k < 3; ++k) {
    CAPTURE(k, one_line.covariance(k, k), two_lines.covariance(k, k));
    // Counting every line as a sample halves the variance: a turn of a pixel over a side is
    // then taken for a move.
    CHECK(two_lines.covariance(k, k) == Approx(one_line.covariance(k, k)).epsilon(0.25));
  }
}

TEST_CASE("pick check: a box dragged far and read by few lines is not pulled back toward no move",
          "[pick_check]") {
  // Six lines across the side that faced the gap, all 40 mm out (a drag), and the side beside it
  // where it was.
  std::vector<pick_check::EdgeSample> samples;
  for (int k = 0; k < 12; ++k) {
    const bool dragged_side = k < 6;
    const double noise_m = 0.0005 * ((k % 2 == 0) ? 1.0 : -1.0);
    samples.push_back(
        side_sample(dragged_side ? 0 : 2, -0.05 + 0.02 * (k % 6), (dragged_side ? 0.040 : 0.0) + noise_m));
  }
  const pick_check::Move move = pick_check::fit_move(samples, 0.0);
  CAPTURE(move.x.transpose(), move.significance());
  // Robust weights taken around no move discount every sample: 30 mm before.
  CHECK(std::abs(move.x.x() - 0.040) < 0.005);
  CHECK(std::abs(move.x.y()) < 0.002);
  CHECK(move.significance() > 9.0);
}

TEST_CASE("pick check: a few lines that read a box's ends tens of millimetres apart do not move it",
          "[pick_check]") {
  // Both long sides read where they were by 30 lines each; the ends by three lines whose steps
  // put the box 45, 79 and 22 mm along (bench seed 91041 frame 36, helios2: a box beside a
  // dragged one called moved 23.4 mm). With one scatter for every sample, the long sides' fixed
  // how well the ends placed the box, and the three lines alone moved it.
  auto samples_with_ends = [](const std::vector<std::pair<int, double>>& ends) {
    std::vector<pick_check::EdgeSample> samples;
    for (int k = 0; k < 60; ++k)
      samples.push_back(side_sample(k < 30 ? 2 : 3, -0.145 + 0.01 * (k % 30), 0.0005 * std::sin(1.3 * k)));
    for (const auto& [side, move_m] : ends)
      samples.push_back(side_sample(side, 0.05 * side, side == 0 ? move_m : -move_m));
    return samples;
  };
  const pick_check::Move scattered =
      pick_check::fit_move(samples_with_ends({{0, -0.045}, {1, -0.079}, {1, -0.022}}), 0.0);
  CAPTURE(scattered.x.transpose(), scattered.significance());
  CHECK(scattered.significance() < 9.0);
  // Three lines that agree still say the box moved (a drag read where little of the side shows).
  const pick_check::Move agreeing =
      pick_check::fit_move(samples_with_ends({{0, -0.022}, {1, -0.023}, {1, -0.021}}), 0.0);
  CAPTURE(agreeing.x.transpose(), agreeing.significance());
  CHECK(agreeing.x.x() < -0.015);  // the weak prior holds it back a little
  CHECK(agreeing.significance() > 9.0);
}
