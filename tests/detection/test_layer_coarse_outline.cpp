// Simplification of a layer outline at a coarse pitch (a 176x132 ToF camera: about 20 mm per
// pixel at 2.8 m). A step between two boxes of a brick layer is a short riser of a few pixels;
// with the layer turned near 45 degrees to the pixel grid the border samples along it follow
// the pixel staircase and its fitted direction tilts by up to about atan(pitch / length). Left
// tilted, the riser moves both corners of the step sideways by most of a pitch and the layout
// search no longer fits the boxes beside it (frame 0056 of the validation set: 5 of 6 boxes).
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

TEST_CASE("a short tilted step riser at a coarse pitch follows the grid", "[layer][simplify]") {
  const double pitch = 0.020;  // [m]
  const double tilt_m = GENERATE(0.006, -0.007);  // riser end offset across it [m]: 7-8 degrees over 0.1 m
  const double yaw = GENERATE(0.0, 43.4 * M_PI / 180.0);
  const Eigen::Vector2d u(std::cos(yaw), std::sin(yaw)), w(-std::sin(yaw), std::cos(yaw));
  const Eigen::Vector2d o(-0.30, -0.20);
  auto at = [&](double a, double b) -> Eigen::Vector2d { return o + a * u + b * w; };
  // Counter-clockwise: a 0.6 x 0.4 m layer with a 0.3 x 0.1 m step out of its top right.
  const std::vector<Eigen::Vector2d> truth{at(0, 0), at(0.6, 0), at(0.6, 0.3), at(0.3, 0.3), at(0.3, 0.4), at(0, 0.4)};
  // Measured outline: the riser's samples (and the ring there) run tilted, from 0.3 + tilt to
  // 0.3 - tilt; elsewhere on the truth. Samples every 5 mm, jittered by up to 2 mm (seeded).
  std::vector<Eigen::Vector2d> measured = truth;
  measured[3] = at(0.3 + tilt_m, 0.3);
  measured[4] = at(0.3 - tilt_m, 0.4);
  std::mt19937 rng(11);
  std::vector<Eigen::Vector2d> samples = walk(measured, 0.005, 0.002, &rng);

  const Ring2d poly = layer::simplify_ring(measured, samples, pitch, ContourParams{});
  INFO("tilt " << tilt_m << " m, yaw " << yaw << " rad, polygon " << describe(poly));
  REQUIRE(poly.size() == truth.size());
  // The step's corners within a quarter pitch (left tilted they lie 6-7 mm off).
  for (const auto& c : truth) CHECK(nearest(poly, c) < 0.25 * pitch);
}

TEST_CASE("a chamfered corner between two edges keeps its diagonal at a coarse pitch", "[layer][simplify]") {
  const double pitch = 0.020;  // [m]
  const double yaw = 43.4 * M_PI / 180.0;
  const Eigen::Vector2d u(std::cos(yaw), std::sin(yaw)), w(-std::sin(yaw), std::cos(yaw));
  auto at = [&](double a, double b) -> Eigen::Vector2d { return a * u + b * w; };
  // A 0.6 x 0.4 m layer with a step and a 0.1 m chamfer (5 pitches along each side) at (0.6, 0).
  const std::vector<Eigen::Vector2d> truth{at(0, 0),     at(0.5, 0),   at(0.6, 0.1), at(0.6, 0.3),
                                           at(0.3, 0.3), at(0.3, 0.4), at(0, 0.4)};
  const std::vector<Eigen::Vector2d> samples = walk(truth, 0.005);
  const Ring2d poly = layer::simplify_ring(truth, samples, pitch, ContourParams{});
  INFO("polygon " << describe(poly));
  REQUIRE(poly.size() == truth.size());
  for (const auto& c : truth) CHECK(nearest(poly, c) < 0.25 * pitch);
}
