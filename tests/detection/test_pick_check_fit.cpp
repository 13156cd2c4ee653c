// The move of a box from its sides' steps (pick_check::fit_move, check_internal.hpp) on
// synthetic samples: how far it moved and how well the samples say so.
#include <cmath>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

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

}  // namespace

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
