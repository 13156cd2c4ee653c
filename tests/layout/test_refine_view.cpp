// Refinement (issue 5): where a box side lies within the pixel footprint depends on the view.
// Seeded synthetic layers seen by an oblique camera: pixels are laid on the layer with a random
// phase; a pixel is on the layer when its footprint lies on a box top, or, across a side that
// faces the camera (its wall hides the floor behind it), when its centre does. A pixel is
// seam-like as soon as its footprint reaches into a gap, except across a side facing the camera.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <random>
#include <utility>

#include <Eigen/Geometry>

#include "../../src/detection/layout/refinement/refine_joint.hpp"
#include "layout_fixtures.hpp"
#include "palletd/detection/layout.hpp"

using namespace palletd;

namespace {

struct ViewBox {
  Eigen::Vector2d center;
  double long_m, short_m;  // long side along x, no yaw
};

/// The refinement input (layer, seams, the search's answer) with the true boxes.
struct ViewScene : layout_test::RefineInput {
  std::vector<ViewBox> truth;
};

const std::vector<BoxFormat> kViewFormats{BoxFormat{0.4, 0.3, "400x300"}};

constexpr double kHeight_m = 2.0;  // camera above the layer

/// Tan of the view angle at a side's middle, outward (> 0: the camera lies beyond the side).
double side_slope(const Eigen::Vector2d& camera_xy, const Eigen::Vector2d& mid, const Eigen::Vector2d& out) {
  return out.dot(camera_xy - mid) / kHeight_m;
}

/// Box extent per side (-x, +x, -y, +y) as the pixels see it: a side facing the camera reaches
/// to where a pixel centre still counts (+0), one facing away only where the whole footprint
/// lies inside (-pitch/2). `grow_facing` is what a facing side adds.
std::array<double, 4> seen_extent(const ViewBox& b, const Eigen::Vector2d& camera_xy, double pitch_m, double grow_facing,
                                  double shrink_away) {
  std::array<double, 4> e{};
  const Eigen::Vector2d h(b.long_m / 2, b.short_m / 2);
  const Eigen::Vector2d outs[4] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d mid = b.center + outs[k].cwiseProduct(h);
    const bool facing = side_slope(camera_xy, mid, outs[k]) > pitch_m / 0.1;
    e[static_cast<std::size_t>(k)] = facing ? grow_facing : -shrink_away;
  }
  return e;
}

bool inside_seen(const ViewBox& b, const std::array<double, 4>& e, const Eigen::Vector2d& p) {
  return p.x() >= b.center.x() - b.long_m / 2 - e[0] && p.x() <= b.center.x() + b.long_m / 2 + e[1] &&
         p.y() >= b.center.y() - b.short_m / 2 - e[2] && p.y() <= b.center.y() + b.short_m / 2 + e[3];
}

/// cols x rows boxes of 400 x 300 with gaps, seen from a camera above `camera_xy`.
ViewScene make_view_block(int cols, int rows, double gap_m, double pitch_m, const Eigen::Vector2d& camera_xy,
                          std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  ViewScene s;
  const double L = 0.4, S = 0.3;
  double bx0 = 1e9, by0 = 1e9, bx1 = -1e9, by1 = -1e9;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      ViewBox b;
      b.long_m = L + 0.002 * u(rng);
      b.short_m = S + 0.002 * u(rng);
      const double jx = 0.002 * u(rng);
      const double jy = 0.002 * u(rng);
      b.center = Eigen::Vector2d(c * (L + gap_m) + L / 2 + jx, r * (S + gap_m) + S / 2 + jy);
      s.truth.push_back(b);
      bx0 = std::min(bx0, b.center.x() - b.long_m / 2); bx1 = std::max(bx1, b.center.x() + b.long_m / 2);
      by0 = std::min(by0, b.center.y() - b.short_m / 2); by1 = std::max(by1, b.center.y() + b.short_m / 2);
    }
  }
  std::vector<std::array<double, 4>> on_layer, not_seam;
  for (const auto& b : s.truth) {
    on_layer.push_back(seen_extent(b, camera_xy, pitch_m, pitch_m / 2, pitch_m / 2));
    not_seam.push_back(seen_extent(b, camera_xy, pitch_m, 0.0, pitch_m / 2));
  }
  const double ox = pitch_m * (u(rng) + 1) / 2, oy = pitch_m * (u(rng) + 1) / 2;
  // One pixel per seam cell: cell centres on pixel centres.
  const Eigen::Vector2d origin_m(bx0 - 0.02 + ox - pitch_m / 2, by0 - 0.02 + oy - pitch_m / 2);
  const layout_test::Rect2d outline{bx0, by0, bx1, by1};
  std::vector<Eigen::Vector2f> points;
  auto seam_share = [&](const layout_test::SeamCell& cell) {
    const Eigen::Vector2d& p = cell.center_m;
    bool layer_point = false, top = false;
    for (std::size_t i = 0; i < s.truth.size(); ++i) {
      layer_point = layer_point || inside_seen(s.truth[i], on_layer[i], p);
      top = top || inside_seen(s.truth[i], not_seam[i], p);
    }
    if (layer_point) points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    // Seams only inside the outline, two cells clear of it (as build_seam_evidence does).
    if (!layout_test::inside_by(outline, 2 * pitch_m, p, p)) return 0.f;
    return top ? 0.f : 1.f;
  };
  layout_test::RefineInput& input = s;
  input =
      layout_test::packed_block_input(outline, cols, rows, kViewFormats[0], origin_m, pitch_m, seam_share);
  s.layer.points_2d = std::move(points);
  // The camera in the layer frame: T_camera_layer maps layer points into the camera frame.
  s.layer.T_camera_layer =
      Eigen::Isometry3d(Eigen::Translation3d(-camera_xy.x(), -camera_xy.y(), -kHeight_m));
  return s;
}

/// Mean position error of the refined boxes [m] and the mean offset vector (shared shift).
std::pair<double, Eigen::Vector2d> refined_error(const ViewScene& s) {
  const LayoutResult r = refine_layout(s.found, s.layer, kViewFormats, &s.seams, LayoutParams{});
  REQUIRE(r.boxes.size() == s.truth.size());
  double sum = 0;
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < s.truth.size(); ++i) {
    sum += (r.boxes[i].center - s.truth[i].center).norm();
    shift += r.boxes[i].center - s.truth[i].center;
  }
  const auto n = static_cast<double>(s.truth.size());
  return {sum / n, shift / n};
}

}  // namespace

TEST_CASE("refine view: footprint corrections follow the side's view", "[refine]") {
  using layout_detail::outline_footprint_correction;
  using layout_detail::seam_footprint_correction;
  const double p = 0.008, drop = 0.1;
  // Facing the camera: the outermost layer point is the edge (half a footprint back).
  CHECK(outline_footprint_correction(0.3, p, drop) == Approx(-p / 2));
  // Facing away or straight down: the edge is a whole footprint beyond the last point's centre.
  CHECK(outline_footprint_correction(-0.3, p, drop) == Approx(p / 2));
  CHECK(outline_footprint_correction(0.0, p, drop) == Approx(p / 2));
  // Half-way up the ramp (the wall hides half a footprint): no correction.
  CHECK(outline_footprint_correction(0.5 * p / drop, p, drop) == Approx(0.0).margin(1e-12));
  // Seam band: half a footprint wide on each side unless the side faces the camera.
  CHECK(seam_footprint_correction(-0.3, p, drop) == Approx(p / 2));
  CHECK(seam_footprint_correction(0.3, p, drop) == Approx(0.0).margin(1e-12));
}

TEST_CASE("refine view: an oblique camera shifts no box toward it", "[refine]") {
  std::mt19937 rng(31);
  const double pitch = 0.008;  // a 352x264 camera at 2.5 m
  // The camera off the layer's -x,-y corner: -x and -y sides face it, +x and +y face away.
  const Eigen::Vector2d camera_xy(-0.6, -0.5);
  // A side parallel to the pixel grid keeps its phase all along (up to +-pitch/2 per side):
  // the bias shows in the mean over random phases.
  const int trials = 12;
  Eigen::Vector2d shift_sum = Eigen::Vector2d::Zero(), blind_sum = Eigen::Vector2d::Zero();
  double err_sum = 0, blind_err_sum = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const ViewScene s = make_view_block(2, 2, 0.010, pitch, camera_xy, rng);
    const auto [err, shift] = refined_error(s);
    // The same pixels without the viewpoint (no camera above the plane): the old half-pixel rule.
    ViewScene blind = s;
    blind.layer.T_camera_layer = Eigen::Isometry3d::Identity();
    const auto [err_blind, shift_blind] = refined_error(blind);
    shift_sum += shift;
    blind_sum += shift_blind;
    err_sum += err;
    blind_err_sum += err_blind;
  }
  const Eigen::Vector2d shift = shift_sum / trials, blind = blind_sum / trials;
  INFO("mean error " << err_sum / trials * 1000 << " mm, mean shift " << shift.transpose() * 1000
                     << " mm; without the view " << blind_err_sum / trials * 1000 << " mm, shift "
                     << blind.transpose() * 1000 << " mm");
  CHECK(shift.norm() < 0.1 * pitch);
  CHECK(err_sum / trials < 0.3 * pitch);
  // Without the view the boxes move toward the camera (-x, -y) by about half a footprint.
  CHECK(blind.x() < -0.25 * pitch);
  CHECK(blind.y() < -0.25 * pitch);
}
