// Seam evidence from a rendered depth frame, and solve_layout end to end on it.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "layout_fixtures.hpp"
#include "palletd/detection/layout.hpp"

using namespace palletd;
using namespace palletd::layout_test;

namespace {

/// A camera 1.5 m above the layer looking straight down; boxes of `l` (layer frame) at 1.5 m,
/// their top faces kInset_m smaller on every side than nominal, so that 4 mm gaps between them
/// show the layer below (1.6 m); the floor around at 2.0 m.
constexpr double kInset_m = 0.002;
struct Scene {
  Frame frame;
  OrganizedCloud cloud;
  LayerResult layer;
};

struct Noise {
  double sigma_m = 0.0;    ///< depth noise
  double dropout = 0.0;    ///< share of pixels without measurement
  unsigned seed = 1;
  /// A bright label (100 x 70 mm, intensity 2600 on tops of 2000) on every box, its long edge
  /// label_inset_m inside the box's +short side and parallel to it; 0 = no labels.
  double label_inset_m = 0.0;
  /// A band of tape this wide (intensity 1400) along the middle of every box; 0 = none.
  double tape_width_m = 0.0;
};

Scene render(const KnownLayout& l, bool gaps_visible, bool with_intensity = false, Noise noise = {}) {
  std::mt19937 rng(noise.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Scene s;
  Intrinsics& in = s.frame.intrinsics;
  in.width = 640;
  in.height = 480;
  in.fx = in.fy = 500.0;
  in.cx = 319.5;
  in.cy = 239.5;
  s.frame.depth_scale_m = 0.0001;
  s.frame.depth.assign(s.frame.pixel_count(), 0);
  if (with_intensity) {
    s.frame.intensity.assign(s.frame.pixel_count(), 300);  // dark gaps and floor
    s.frame.intensity_bits = 16;
  }
  s.layer.status = DetectionStatus::kOk;
  s.layer.plane_camera.normal = Eigen::Vector3d(0, 0, -1);
  s.layer.plane_camera.d = 1.5;
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // layer x = camera x, layer y = -camera y, layer z = -camera z
  s.layer.T_camera_layer.linear() = R;
  s.layer.T_camera_layer.translation() = Eigen::Vector3d(0, 0, 1.5);
  s.layer.polygons = union_outline(l);
  const auto truth = truth_boxes(l);
  s.cloud.width = in.width;
  s.cloud.height = in.height;
  s.cloud.points.assign(s.frame.pixel_count(), Eigen::Vector3f::Constant(NAN));
  auto on_label = [&](const Eigen::Vector2d& p) {
    if (!(noise.label_inset_m > 0)) return false;
    for (const auto& b : truth) {
      const double c = std::cos(b.yaw_rad), sn = std::sin(b.yaw_rad);
      const Eigen::Vector2d d = p - b.center;
      const double along = c * d.x() + sn * d.y(), across = -sn * d.x() + c * d.y();
      const double edge = b.short_m / 2 - noise.label_inset_m;
      if (std::abs(along) <= 0.05 && across <= edge && across >= edge - 0.07) return true;
    }
    return false;
  };
  auto on_tape = [&](const Eigen::Vector2d& p) {
    if (!(noise.tape_width_m > 0)) return false;
    for (const auto& b : truth) {
      const Eigen::Vector2d d = p - b.center;
      const double along = std::cos(b.yaw_rad) * d.x() + std::sin(b.yaw_rad) * d.y();
      const double across = -std::sin(b.yaw_rad) * d.x() + std::cos(b.yaw_rad) * d.y();
      if (std::abs(along) <= b.long_m / 2 && std::abs(across) <= noise.tape_width_m / 2) return true;
    }
    return false;
  };
  auto inside_box = [&](const Eigen::Vector2d& p) {
    for (const auto& b : truth) {
      const double c = std::cos(b.yaw_rad), sn = std::sin(b.yaw_rad);
      const Eigen::Vector2d d = p - b.center;
      if (std::abs(c * d.x() + sn * d.y()) <= b.long_m / 2 - kInset_m &&
          std::abs(-sn * d.x() + c * d.y()) <= b.short_m / 2 - kInset_m) {
        return true;
      }
    }
    return false;
  };
  for (int v = 0; v < in.height; ++v) {
    for (int u = 0; u < in.width; ++u) {
      const double rx = (u - in.cx) / in.fx, ry = (v - in.cy) / in.fy;
      const Eigen::Vector2d layer_xy(rx * 1.5, -ry * 1.5);
      double z = 2.0;
      const std::size_t i = static_cast<std::size_t>(v) * static_cast<std::size_t>(in.width) + static_cast<std::size_t>(u);
      if (inside_box(layer_xy)) {
        z = 1.5;
        if (with_intensity)
          s.frame.intensity[i] = on_label(layer_xy) ? 2600 : (on_tape(layer_xy) ? 1400 : 2000);
        s.layer.points_2d.emplace_back(static_cast<float>(layer_xy.x()), static_cast<float>(layer_xy.y()));
        s.layer.point_pixels.push_back(static_cast<std::int32_t>(i));
      } else if (clipped_area(s.layer.polygons[0], layer_xy.x() - 1e-4, layer_xy.y() - 1e-4, layer_xy.x() + 1e-4,
                              layer_xy.y() + 1e-4) > 0) {
        z = gaps_visible ? 1.6 : 1.5;
      }
      if (noise.sigma_m > 0) z += noise.sigma_m * gauss(rng);
      if (noise.dropout > 0 && uni(rng) < noise.dropout) continue;  // depth 0, point NaN
      s.frame.depth[i] = static_cast<std::uint16_t>(std::lround(z / s.frame.depth_scale_m));
      s.cloud.points[i] = Eigen::Vector3f(static_cast<float>(rx * z), static_cast<float>(ry * z), static_cast<float>(z));
    }
  }
  return s;
}

/// Moves the layout so that its boxes' centroid is under the camera (the layer stays in view).
KnownLayout centred(KnownLayout l) {
  l.offset = Eigen::Vector2d::Zero();
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  const auto boxes = truth_boxes(l);
  for (const auto& b : boxes) c += b.center;
  l.offset = -c / static_cast<double>(boxes.size());
  return l;
}

KnownLayout centred_pinwheel(bool mirrored) {
  KnownLayout l = pinwheel(0.4, 0.3, mirrored);
  l.theta_rad = 0.12;
  l.offset = {-0.33, -0.36};
  return l;
}

/// solve_layout on a rendered scene must give one unflagged layout whose centres lie within
/// max_err_m of the truth; returns it for further checks.
LayoutResult solve_unflagged(const KnownLayout& l, const Scene& s, double max_err_m) {
  LayoutParams p;
  p.search.time_budget_ms = 500;
  const LayoutResult r = solve_layout(s.frame, s.cloud, s.layer, l.formats, p);
  REQUIRE(r.status == DetectionStatus::kOk);
  CHECK_FALSE(r.ambiguous);
  const double err = match_error(truth_boxes(l), r.boxes);
  CHECK(err >= 0.0);
  CHECK(err < max_err_m);
  return r;
}

}  // namespace

TEST_CASE("seam evidence from depth marks the gaps between boxes, not the box tops") {
  const KnownLayout l = centred_pinwheel(false);
  const Scene s = render(l, true);
  const SeamEvidence ev = build_seam_evidence(s.frame, s.cloud, s.layer);
  REQUIRE_FALSE(ev.empty());
  CHECK(ev.cell_m == Approx(0.003).margin(1e-6));
  CHECK(ev.strength > 0.003);
  auto value_at = [&](const Eigen::Vector2d& p) {
    const int ix = static_cast<int>((p.x() - ev.origin_m.x()) / ev.cell_m);
    const int iy = static_cast<int>((p.y() - ev.origin_m.y()) / ev.cell_m);
    return ev.at(ix, iy);
  };
  for (const auto& b : truth_boxes(l)) CHECK(value_at(b.center) < 0.1f);
  const Scene flat = render(l, false);
  const SeamEvidence none = build_seam_evidence(flat.frame, flat.cloud, flat.layer);
  CHECK(none.strength < 0.002);
  LayerResult bad = s.layer;
  bad.status = DetectionStatus::kNoPlane;
  CHECK(build_seam_evidence(s.frame, s.cloud, bad).empty());
}

TEST_CASE("solve_layout resolves pinwheel chirality from depth seams and refines to millimetres") {
  for (bool mirrored : {false, true}) {
    const KnownLayout l = centred_pinwheel(mirrored);
    const Scene s = render(l, true);
    const LayoutResult r = solve_unflagged(l, s, 0.003);
    CHECK(r.coverage > 0.95);
    for (const LayoutBox& b : r.boxes) CHECK(b.score > 0.6);
  }
}

TEST_CASE("solve_layout flags the pinwheel ambiguous when the gaps are invisible") {
  const KnownLayout l = centred_pinwheel(false);
  const Scene s = render(l, false);
  LayoutParams p;
  p.search.time_budget_ms = 500;
  const LayoutResult r = solve_layout(s.frame, s.cloud, s.layer, l.formats, p);
  REQUIRE(r.status == DetectionStatus::kOk);
  CHECK(r.ambiguous);
}

TEST_CASE("dark lines in the intensity alone resolve the pinwheel when depth shows no gap") {
  LayoutParams p;
  p.search.time_budget_ms = 500;
  for (bool mirrored : {false, true}) {
    const KnownLayout l = centred_pinwheel(mirrored);
    const Scene s = render(l, false, true);
    const LayoutResult r = solve_layout(s.frame, s.cloud, s.layer, l.formats, p);
    REQUIRE(r.status == DetectionStatus::kOk);
    CHECK_FALSE(r.ambiguous);
    CHECK(match_error(truth_boxes(l), r.boxes) >= 0.0);
  }
}

TEST_CASE("evidence built once lays the layer out as solve_layout builds it, for each format") {
  // The detection of unknown cartons lays one layer out with many sizes on evidence built once.
  // The expansion budget alone ends the searches (no wall-clock cap under sanitizers).
  LayoutParams p;
  p.search.time_budget_ms = 1e6;
  const KnownLayout l = centred_pinwheel(false);
  const Scene s = render(l, false, true);
  const LayerEvidence evidence = build_layer_evidence(s.frame, s.cloud, s.layer, p.seams);
  REQUIRE_FALSE(evidence.seams.empty());
  for (const BoxFormat& f : {l.formats.front(), BoxFormat{0.3, 0.2, "", 0.0}}) {
    const LayoutResult own = solve_layout(s.frame, s.cloud, s.layer, {f}, p);
    const LayoutResult reused = solve_layout(s.frame, s.cloud, s.layer, evidence, {f}, p);
    REQUIRE(own.boxes.size() == reused.boxes.size());
    CHECK(own.ambiguous == reused.ambiguous);
    CHECK(own.rim_share == reused.rim_share);
    for (std::size_t i = 0; i < own.boxes.size(); ++i) {
      CHECK(own.boxes[i].center.isApprox(reused.boxes[i].center));
      CHECK(own.boxes[i].yaw_rad == reused.boxes[i].yaw_rad);
    }
  }
  LayerResult none = s.layer;
  none.status = DetectionStatus::kNoLayer;
  CHECK(solve_layout(s.frame, s.cloud, none, evidence, l.formats, p).status == DetectionStatus::kNoLayer);
}

TEST_CASE("labels near box sides: their edges are no seams, the dark gaps are") {
  // Depth shows no gap; the intensity shows the gaps as dark lines and, on every box, a bright
  // label whose edge runs 20 mm inside a side. A label's edges are steps, not lines darker than
  // both sides: they must not look like seams, or the refinement takes them for box sides.
  const KnownLayout l = centred_pinwheel(false);
  const Scene s = render(l, false, true, Noise{0.0, 0.0, 1U, 0.02});
  const SeamEvidence ev = build_seam_evidence(s.frame, s.cloud, s.layer);
  REQUIRE_FALSE(ev.empty());
  auto value_at = [&](const Eigen::Vector2d& p) {
    const int ix = static_cast<int>((p.x() - ev.origin_m.x()) / ev.cell_m);
    const int iy = static_cast<int>((p.y() - ev.origin_m.y()) / ev.cell_m);
    return ev.at(ix, iy);
  };
  // Strongest raster value across a line at `inset` inside each box's +short side, sampled
  // along the label's length.
  auto line_peak = [&](const Box2d& b, double inset_m) {
    const Eigen::Vector2d along(std::cos(b.yaw_rad), std::sin(b.yaw_rad)), across(-along.y(), along.x());
    double weakest = 1.0;  // the weakest of the samples along the line, each the peak across it
    for (double t = -0.04; t <= 0.04; t += 0.01) {
      float peak = 0.f;
      for (double o = -0.004; o <= 0.004; o += 0.001)
        peak = std::max(peak, value_at(b.center + t * along + (b.short_m / 2 - inset_m + o) * across));
      weakest = std::min(weakest, static_cast<double>(peak));
    }
    return weakest;
  };
  for (const auto& b : truth_boxes(l)) {
    CHECK(line_peak(b, 0.02) < 0.2);          // the label's outer edge
    CHECK(line_peak(b, 0.09) < 0.2);          // its inner edge
  }
  CHECK(ev.strength > 0.003);  // the dark gaps stand out
  solve_unflagged(l, s, 0.003);
}

TEST_CASE("solve_layout on rendered layers: exact layouts, centres within 3 mm") {
  std::vector<KnownLayout> layouts = {brick(), grid_200x150(40), l_shaped(), mixed_formats()};
  for (KnownLayout l : layouts) {
    l.theta_rad = -0.2;
    l = centred(l);
    INFO(l.name);
    // Several formats: where one carton stands rather than two pressed together, its tape shows.
    const bool mixed = l.formats.size() > 1;
    solve_unflagged(l, render(l, true, mixed, Noise{0.0, 0.0, 1U, 0.0, mixed ? 0.048 : 0.0}), 0.003);
  }
}

TEST_CASE("solve_layout with depth noise and dropouts") {
  for (KnownLayout l : {brick(), grid_200x150(40), pinwheel(0.4, 0.3, true)}) {
    l.theta_rad = 0.25;
    l = centred(l);
    INFO(l.name);
    solve_unflagged(l, render(l, true, false, Noise{0.0015, 0.02, 5U}), 0.004);
  }
}

TEST_CASE("a line of pixels without depth is a seam when it is dark, not when it is as bright as the tops") {
  // A glint (or saturation) leaves pixels without depth on a bright top; a gap leaves them
  // without depth and dark. Both as a line across the middle of a box, depth showing no gap.
  const KnownLayout l = centred_pinwheel(false);
  const Box2d box = truth_boxes(l).front();
  auto with_line = [&](std::uint16_t intensity) {
    Scene s = render(l, false, true);
    const Eigen::Vector2d across(-std::sin(box.yaw_rad), std::cos(box.yaw_rad));
    for (double t = -0.12; t <= 0.12; t += 0.001) {
      const Eigen::Vector2d q = box.center + t * across;  // layer frame: camera x, -camera y at 1.5 m
      const int u = static_cast<int>(std::lround(q.x() / 1.5 * 500.0 + 319.5));
      const int v = static_cast<int>(std::lround(-q.y() / 1.5 * 500.0 + 239.5));
      const std::size_t i = static_cast<std::size_t>(v) * 640 + static_cast<std::size_t>(u);
      s.frame.depth[i] = 0;
      s.cloud.points[i] = Eigen::Vector3f::Constant(NAN);
      s.frame.intensity[i] = intensity;
    }
    return s;
  };
  auto peak_at_centre = [&](const Scene& s) {
    const SeamEvidence ev = build_seam_evidence(s.frame, s.cloud, s.layer);
    REQUIRE_FALSE(ev.empty());
    const Eigen::Vector2d along(std::cos(box.yaw_rad), std::sin(box.yaw_rad));
    float peak = 0.f;
    for (double o = -0.006; o <= 0.006; o += 0.001) {
      const Eigen::Vector2d p = box.center + o * along;
      peak = std::max(peak, ev.at(static_cast<int>((p.x() - ev.origin_m.x()) / ev.cell_m),
                                  static_cast<int>((p.y() - ev.origin_m.y()) / ev.cell_m)));
    }
    return peak;
  };
  CHECK(peak_at_centre(with_line(2000)) < 0.2f);  // as bright as the top: a glint
  CHECK(peak_at_centre(with_line(300)) > 0.8f);   // dark: a gap
  // Without intensity, a pixel without depth counts as a gap.
  Scene no_intensity = with_line(2000);
  no_intensity.frame.intensity.clear();
  no_intensity.frame.intensity_bits = 0;
  CHECK(peak_at_centre(no_intensity) > 0.8f);
}
