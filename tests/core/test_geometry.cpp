#include <catch2/catch.hpp>

#include "palletd/core/geometry.hpp"

TEST_CASE("polygon area subtracts holes and ring orientation sets the sign") {
  palletd::PolygonWithHoles p;
  p.outer = {{0, 0}, {2, 0}, {2, 1}, {0, 1}};
  CHECK(palletd::signed_area(p.outer) == Approx(2.0));
  p.holes.push_back({{0.5, 0.25}, {0.5, 0.75}, {1.0, 0.75}, {1.0, 0.25}});
  CHECK(palletd::signed_area(p.holes[0]) == Approx(-0.25));
  CHECK(palletd::area(p) == Approx(1.75));
}

TEST_CASE("box corners are counter-clockwise around the centre") {
  palletd::Box2d b;
  b.center = {1.0, 2.0};
  b.yaw_rad = M_PI / 2;
  b.long_m = 0.4;
  b.short_m = 0.2;
  const auto c = b.corners();
  REQUIRE(c.size() == 4);
  CHECK(palletd::signed_area(c) == Approx(0.08));
  CHECK(c[0].x() == Approx(1.1));
  CHECK(c[0].y() == Approx(1.8));
}

TEST_CASE("an undirected axis' yaw is folded to -90 < yaw <= 90") {
  CHECK(palletd::axis_yaw_deg({1.0, 0.0, 0.0}) == Approx(0.0));
  CHECK(palletd::axis_yaw_deg({-1.0, 0.0, 0.0}) == Approx(0.0).margin(1e-9));
  CHECK(palletd::axis_yaw_deg({0.0, 1.0, 0.0}) == Approx(90.0));
  CHECK(palletd::axis_yaw_deg({0.0, -1.0, 0.0}) == Approx(90.0));
  CHECK(palletd::axis_yaw_deg({1.0, -1.0, 0.5}) == Approx(-45.0));
  CHECK(palletd::axis_yaw_deg({-1.0, 1.0, 0.0}) == Approx(-45.0));
}
