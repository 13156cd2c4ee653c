// Box sides measured from the side observations alone (refinement/measured_sizes.hpp): a box's
// own pair of sides, and its share of a row of boxes pressed together between two seen sides.
#include <catch2/catch.hpp>

#include "../../src/detection/layout/refinement/measured_sizes.hpp"

using namespace palletd::layout_detail;

namespace {

JointBox box_at(double x, double half_x, double half_y) {
  JointBox b;
  b.center = {x, 0.0};
  b.half = b.half_nominal = {half_x, half_y};
  return b;
}

}  // namespace

TEST_CASE("a box with both sides of an axis seen measures their distance", "[refine][measured_sizes]") {
  const std::vector<SideObservation> sides = {{0, 0, -1, -0.201, 0.001}, {0, 0, 1, 0.203, 0.001},
                                              {0, 1, -1, -0.150, 0.001}};
  const Eigen::Vector2d m = measured_extent(sides, 0);
  CHECK(m.x() == Approx(0.404));
  CHECK(m.y() == -1.0);  // one side of y only
  CHECK(measured_extent(sides, 1) == Eigen::Vector2d(-1.0, -1.0));
}

TEST_CASE("a row of pressed boxes between two seen sides shares its length", "[refine][measured_sizes]") {
  // Three 0.4 m boxes in a row along x, pressed together, outer sides seen 1.17 m apart.
  const std::vector<JointBox> boxes = {box_at(-0.4, 0.2, 0.15), box_at(0.0, 0.2, 0.15), box_at(0.4, 0.2, 0.15)};
  const std::vector<SideObservation> sides = {{0, 0, -1, -0.585, 0.001}, {2, 0, 1, 0.585, 0.001}};
  const std::vector<Contact> contacts = {{0, 1, 0, 0.001}, {1, 2, 0, 0.001}};
  for (std::size_t k = 0; k < 3; ++k) {
    const Eigen::Vector2d r = run_extent(sides, contacts, boxes, k);
    CHECK(r.x() == Approx(0.39));
    CHECK(r.y() == -1.0);
  }
  // A seam seen between the first two (no contact): the row is broken.
  const std::vector<Contact> broken = {{1, 2, 0, 0.001}};
  CHECK(run_extent(sides, broken, boxes, 0).x() == -1.0);
  // A box of another nominal size in the row: no shared length.
  std::vector<JointBox> mixed = boxes;
  mixed[1].half_nominal.x() = 0.15;
  CHECK(run_extent(sides, contacts, mixed, 1).x() == -1.0);
}
