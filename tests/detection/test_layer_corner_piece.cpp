// Simplification of a layer outline: a short piece at the start of a side (Douglas-Peucker cut
// the side at a kink of the pixel ring a few centimetres from the corner) must not merge into
// the long neighbouring side across the corner. Its few samples hardly raise the union's rms,
// but merged into the long side they leave the corner at the piece's far end: the outline loses
// a wedge along the whole long side and a box of the layer no longer fits it.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "layer_stages.hpp"
#include "outline_test_util.hpp"
#include "palletd/detection/layer.hpp"

using namespace palletd;
using palletd::testing::describe;
using palletd::testing::nearest;
using palletd::testing::walk;

namespace {

}  // namespace

TEST_CASE("a short piece across a corner stays with its own side", "[layer][simplify]") {
  const double pitch = 0.004;  // [m] a VGA camera at 2.3 m
  const double long_m = 0.630, short_m = 0.232, piece_m = GENERATE(0.026, 0.030);
  const double yaw = GENERATE(0.0, 43.5 * 3.14159265358979323846 / 180.0);
  const Eigen::Vector2d u(std::cos(yaw), std::sin(yaw)), w(-std::sin(yaw), std::cos(yaw));
  const Eigen::Vector2d o(0.10, -0.30);
  // Counter-clockwise corners: c0 -> c1 is a long side, c1 -> c2 a short one.
  const std::vector<Eigen::Vector2d> corners{o, o + long_m * u, o + long_m * u + short_m * w, o + short_m * w};
  // The pixel ring: the corners, and on the short side after c1 a kink 7 mm outward (beyond the
  // simplification tolerance) `piece_m` from the corner.
  std::vector<Eigen::Vector2d> ring{corners[0], corners[1], corners[1] + piece_m * w + 0.007 * u, corners[2],
                                    corners[3]};
  // Border samples on the true outline every 3 mm, jittered by up to 1 mm across it (seeded),
  // plus a few stray points 3 pitches outside the middle of the far long side (a flying-pixel
  // cluster), so that no single rectangle explains every sample.
  std::mt19937 rng(7);
  std::vector<Eigen::Vector2d> samples = walk(corners, 0.003, 0.001, &rng);
  const Eigen::Vector2d mid_far = 0.5 * (corners[2] + corners[3]);
  for (int i = -8; i <= 8; ++i) samples.push_back(mid_far + 0.003 * i * u + 3.0 * pitch * w);

  const Ring2d poly = layer::simplify_ring(ring, samples, pitch, ContourParams{});
  INFO("piece " << piece_m << " m, yaw " << yaw << " rad, polygon " << describe(poly));
  REQUIRE(poly.size() >= 4);
  for (const auto& c : corners) CHECK(nearest(poly, c) < pitch);
  CHECK(std::abs(std::abs(signed_area(poly)) - long_m * short_m) < 0.01 * long_m * short_m);
}
