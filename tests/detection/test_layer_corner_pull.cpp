// Simplification of a layer outline at the ends of long edges:
// - a right-angled corner the raster blunted, whose short cut merged into the long edge's line,
//   comes back to the crossing of the two long lines (a corner left on the cut tilts the long
//   edge and, through it, the layout frame); a real chamfer of the same size stays;
// - a short piece of a long edge whose few samples fit a tilted line (a coarse pixel staircase)
//   joins the long edge when it lies on it (offset measured across the ring's grid axis).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
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

/// Direction of the polygon edge nearest to the midpoint of a..b, mod 180 deg, against a..b [deg].
double edge_tilt_deg(const Ring2d& poly, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d mid = 0.5 * (a + b), dir = (b - a).normalized();
  double best = 1e9, tilt = 90.0;
  for (std::size_t k = 0; k < poly.size(); ++k) {
    const Eigen::Vector2d p = poly[k], q = poly[(k + 1) % poly.size()];
    const Eigen::Vector2d d = q - p;
    const double t = std::clamp((mid - p).dot(d) / std::max(d.squaredNorm(), 1e-12), 0.0, 1.0);
    const double dist = (p + t * d - mid).norm();
    if (dist < best) {
      best = dist;
      tilt = std::acos(std::min(1.0, std::abs(d.normalized().dot(dir)))) * 180.0 / M_PI;
    }
  }
  return tilt;
}

}  // namespace

TEST_CASE("simplify: a blunted corner at the end of a long edge comes back, a chamfer stays") {
  // A brick-like layer edge: 1.2 m long (four 300 mm boxes), its end corner blunted by the ring
  // through the border pixel centres: the ring leaves the long edge 11 mm before the corner and
  // meets the short edge 31 mm above it (seen in a helios2 frame at 4 mm pixels). The cut's
  // line merges into the long edge's; the crossing of the two long lines lies farther from the
  // vertex left on the short edge than a plain corner may move, so the corner stayed blunted and
  // the long edge came out tilted by 1.5 deg.
  const double pitch = 0.004, along = 0.011, up = 0.031;
  const std::vector<Eigen::Vector2d> shape{{0.0, 0.0}, {1.2, 0.0}, {1.2, 0.2}, {0.3, 0.2}, {0.3, 0.4}, {0.0, 0.4}};
  const std::size_t blunted = 1;  // the corner (1.2, 0)
  const Eigen::Vector2d before = shape[blunted] + Eigen::Vector2d(-along, 0.0);
  const Eigen::Vector2d after = shape[blunted] + Eigen::Vector2d(0.0, up);
  std::vector<Eigen::Vector2d> cut_shape;
  for (std::size_t k = 0; k < shape.size(); ++k) {
    if (k != blunted) {
      cut_shape.push_back(shape[k]);
      continue;
    }
    cut_shape.push_back(before);
    cut_shape.push_back(after);
  }
  const std::vector<Eigen::Vector2d> ring = walk(cut_shape, pitch);
  for (const double yaw : {0.0, 0.47, 1.2}) {
    const Eigen::Rotation2Dd R(yaw);
    std::vector<Eigen::Vector2d> rotated_ring;
    for (const auto& p : ring) rotated_ring.push_back(R * p);
    SECTION("blunted by the raster, yaw " + std::to_string(yaw)) {
      // The edge samples follow the box edges into the corner.
      std::vector<Eigen::Vector2d> samples;
      for (const auto& p : walk(shape, 0.5 * pitch)) samples.push_back(R * p);
      const Ring2d poly = layer::simplify_ring(rotated_ring, samples, pitch, ContourParams{});
      INFO(describe(poly));
      CHECK(nearest(poly, R * shape[blunted]) < 0.5 * pitch);
      // The long edge keeps its direction (a tilt of 0.3 deg moves its far end by 6 mm).
      CHECK(edge_tilt_deg(poly, R * shape[0], R * shape[1]) < 0.1);
    }
    SECTION("chamfered, yaw " + std::to_string(yaw)) {
      // The edge samples follow the cut: the corner is missing and stays missing.
      std::vector<Eigen::Vector2d> samples;
      for (const auto& p : walk(cut_shape, 0.5 * pitch)) samples.push_back(R * p);
      const Ring2d poly = layer::simplify_ring(rotated_ring, samples, pitch, ContourParams{});
      INFO(describe(poly));
      CHECK(nearest(poly, R * shape[blunted]) > 1.0 * pitch);
    }
  }
}

TEST_CASE("simplify: a tilted short piece in line with a long edge joins it at a coarse pitch") {
  // An L of 600 x 430 mm blocks at 20 mm pixels (o3d303 binned, 2.5 m away). The last 170 mm of
  // its 860 mm left edge come out of the raster as a staircase leaning 10 deg either way about
  // the edge (seen in an o3d303 frame: 11 deg): Douglas-Peucker splits them off and their fit
  // leans as much, within the merge angle. Measured across the leaning piece, the long edge's
  // centre seems 70 mm off; measured across the ring's grid axis (the long edge's direction),
  // the piece lies on it. Kept apart, the polygon gains a false vertex and the corner at the
  // top of the edge moves.
  const double pitch = 0.02, lean = 0.015, piece = 0.17;
  const std::vector<Eigen::Vector2d> shape{{0.0, 0.0}, {0.6, 0.0}, {0.6, 0.43}, {0.3, 0.43}, {0.3, 0.86}, {0.0, 0.86}};
  auto staircase = [&](std::vector<Eigen::Vector2d> pts, double sign) {
    for (auto& p : pts) {
      if (std::abs(p.x()) < 1e-9 && p.y() > 0.86 - piece) p.x() = sign * lean * (2.0 * (p.y() - (0.86 - piece)) / piece - 1.0);
    }
    return pts;
  };
  for (const double sign : {1.0, -1.0}) {
    for (const double yaw : {0.0, 0.6}) {
      const Eigen::Rotation2Dd R(yaw);
      std::vector<Eigen::Vector2d> ring, samples;
      for (const auto& p : staircase(walk(shape, pitch), sign)) ring.push_back(R * p);
      // Samples alternately in and out of the edges, as the steps of a coarse raster leave them
      // (their rms about a fitted edge 6 mm, more than a noise-split edge may show).
      double side = 1.0;
      for (const auto& p : staircase(walk(shape, 0.5 * pitch), sign)) {
        samples.push_back(R * (p + side * 0.3 * pitch * Eigen::Vector2d(1.0, 1.0)));
        side = -side;
      }
      const Ring2d poly = layer::simplify_ring(ring, samples, pitch, ContourParams{});
      INFO("lean " << sign << " yaw " << yaw << ": " << describe(poly));
      CHECK(poly.size() == shape.size());
      for (const auto& c : shape) CHECK(nearest(poly, R * c) < 0.5 * pitch);
    }
  }
}
