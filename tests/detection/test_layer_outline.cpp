// Outline placement at a coarse pixel pitch, the "outline along invalid pixels" diagnostic, and
// detect() with a caller-owned workspace.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"
#include "outline_test_util.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/layer.hpp"
#include "synthetic_scene.hpp"

using namespace palletd;
using palletd::testing::describe;
using palletd::testing::nearest;
using palletd::testing::walk;
using namespace palletd::testing;

namespace {

constexpr double kCartonArea = 0.315 * 0.232;

LayerResult run_layer(const SynthFrame& f, LayerParams lp = {}, LayerTrace* trace = nullptr) {
  return extract_layer(f.frame, f.cloud, PlaneParams{}, lp, ContourParams{}, 0.5 * kCartonArea, trace);
}

double segment_distance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& q) {
  const Eigen::Vector2d d = b - a;
  const double t = std::clamp((q - a).dot(d) / std::max(d.squaredNorm(), 1e-12), 0.0, 1.0);
  return (a + t * d - q).norm();
}

/// A shape rasterised at a pitch of `pitch_x_m` x `pitch_y_m` as extract_layer sees it: the ring through the border
/// pixel centres (traced by findContours) and one edge sample per border pixel and off-shape
/// 4-neighbour, where the outline crosses the step between them (with its border pixel as origin).
struct Rasterised {
  std::vector<Eigen::Vector2d> ring, samples, origins;
};

/// `whole_footprint`: a pixel is on the shape only when its whole footprint is (a ToF pixel at a
/// depth step mixes top and floor and leaves the band), and a sample may then lie up to two
/// steps out, where the outline crosses the line through the border pixel and its neighbour.
template <typename Inside>
Rasterised rasterise_xy(const Inside& inside, double pitch_x_m, double pitch_y_m, int w, int h,
                        bool whole_footprint = false) {
  auto centre = [&](int u, int v) { return Eigen::Vector2d((u - w / 2) * pitch_x_m, (v - h / 2) * pitch_y_m); };
  auto on = [&](const Eigen::Vector2d& c) {
    if (!whole_footprint) return inside(c);
    for (const double dx : {-0.5, 0.5})
      for (const double dy : {-0.5, 0.5})
        if (!inside(c + Eigen::Vector2d(dx * pitch_x_m, dy * pitch_y_m))) return false;
    return true;
  };
  cv::Mat mask(h, w, CV_8U, cv::Scalar(0));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      if (on(centre(u, v))) mask.at<std::uint8_t>(v, u) = 255;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  Rasterised r;
  if (contours.size() != 1) return r;
  static const int du[4] = {-1, 1, 0, 0};
  static const int dv[4] = {0, 0, -1, 1};
  cv::Mat seen(h, w, CV_8U, cv::Scalar(0));
  for (const cv::Point& p : contours[0]) {
    if (seen.at<std::uint8_t>(p) != 0) continue;
    seen.at<std::uint8_t>(p) = 1;
    const Eigen::Vector2d q = centre(p.x, p.y);
    r.ring.push_back(q);
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d o = centre(p.x + du[k], p.y + dv[k]);
      if (on(o)) continue;
      double lo = 0.0, hi = whole_footprint ? 2.0 : 1.0;
      if (inside(q + hi * (o - q))) continue;
      for (int it = 0; it < 40; ++it) {
        const double mid = 0.5 * (lo + hi);
        (inside(q + mid * (o - q)) ? lo : hi) = mid;
      }
      r.samples.push_back(q + lo * (o - q));
      r.origins.push_back(q);
    }
  }
  return r;
}

template <typename Inside>
Rasterised rasterise(const Inside& inside, double pitch_m, int w, int h, bool whole_footprint = false) {
  return rasterise_xy(inside, pitch_m, pitch_m, w, h, whole_footprint);
}

}  // namespace

TEST_CASE("simplify: samples beyond foreshortened pixel steps still place the edges") {
  // A rotated box rasterised on an anisotropic grid (16 x 28 mm: a far edge seen at a tilt); the
  // ring runs through border pixel centres, each sample lies where the box edge crosses the step
  // from a border pixel to its off-box 4-neighbour (up to a whole 28 mm step out).
  const double px = 0.016, py = 0.028, yaw = 0.45;
  const Eigen::Rotation2Dd R(yaw);
  const std::vector<Eigen::Vector2d> truth{R * Eigen::Vector2d(-0.1575, -0.116), R * Eigen::Vector2d(0.1575, -0.116),
                                           R * Eigen::Vector2d(0.1575, 0.116), R * Eigen::Vector2d(-0.1575, 0.116)};
  auto inside = [&](const Eigen::Vector2d& q) {
    const Eigen::Vector2d l = R.inverse() * q;
    return std::abs(l.x()) <= 0.1575 && std::abs(l.y()) <= 0.116;
  };
  const Rasterised r = rasterise_xy(inside, px, py, 40, 24);
  REQUIRE_FALSE(r.ring.empty());
  const Ring2d poly = layer::simplify_ring(r.ring, r.samples, py, ContourParams{}, &r.origins);
  std::string corners;
  for (const auto& c : poly) corners += "(" + std::to_string(c.x()) + ", " + std::to_string(c.y()) + ") ";
  INFO(corners);
  REQUIRE(poly.size() == 4);
  for (const auto& t : truth) CHECK(nearest(poly, t) < 0.004);
}

TEST_CASE("coarse pitch at a tilt: edges facing away from the camera are not pulled in") {
  // 176x132 pixels, f = 152 px, 2.5 m: a pitch of 16 mm on the layer (o3d303 binned). One box
  // on a floor a metre below, no noise: the outline must lie within half a pitch of the truth
  // on every side, including the far side whose off-layer pixels see the floor.
  const SynthScene s = single_box(0.6, 0.4, 0.5, 1.0);
  SynthNoise quiet;
  quiet.sigma_m = 0.0;
  quiet.dropout = 0.0;
  quiet.flying = 0.0;
  for (const double azimuth : {0.0, 90.0, 200.0}) {
    SynthCamera cam = camera_looking_at(1.0, 25.0, azimuth);
    cam.width = 176;
    cam.height = 132;
    cam.fx = cam.fy = 152.0;
    cam.distance_m = 2.5;
    const SynthFrame f = render_synthetic(s, cam, quiet);
    const LayerResult r = run_layer(f);
    INFO("azimuth " << azimuth << " reason " << r.reason);
    REQUIRE(r.status == DetectionStatus::kOk);
    REQUIRE(r.polygons.size() == 1);
    const auto truth = truth_in_layer(s, f, r.T_camera_layer);
    CHECK(polygon_iou(r.polygons, truth) > 0.96);
    // Every side, the middle 40 % of it: the outline within half a pitch (near the corners the
    // outline follows the corner placement, which at 16 mm pixels may be blunted by a pitch).
    const double pitch_m = 2.5 / 152.0;
    const Ring2d& outer = r.polygons[0].outer;
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d p0 = truth[0][k], p1 = truth[0][(k + 1) % 4];
      for (double t = 0.3; t <= 0.71; t += 0.1) {
        const Eigen::Vector2d q = p0 + t * (p1 - p0);
        double best = 1e9;
        for (std::size_t i = 0; i < outer.size(); ++i) best = std::min(best, segment_distance(outer[i], outer[(i + 1) % outer.size()], q));
        INFO("side " << k << " at " << t);
        CHECK(best < 0.5 * pitch_m);
      }
    }
    CHECK_FALSE(r.diagnostics.outline_along_invalid);
  }
}

TEST_CASE("outline along invalid pixels: flagged when the depth ends, not for a narrow shadow") {
  const SynthScene scene = grid_layer(3, 3, 0.0, 1.0, true);
  const SynthCamera cam = camera_looking_at(1.0);
  const SynthFrame full = render_synthetic(scene, cam, SynthNoise{});
  LayerTrace trace;
  const LayerResult observed = run_layer(full, {}, &trace);
  REQUIRE(observed.status == DetectionStatus::kOk);
  // 2 % random dropouts beside the outline are no unobserved outline.
  CHECK(observed.diagnostics.unobserved_outline_fraction < 0.01);
  CHECK_FALSE(observed.diagnostics.outline_along_invalid);
  // The layer's rightmost column per image row.
  std::vector<int> right(static_cast<std::size_t>(trace.height), -1);
  int u_min = trace.width, u_max = -1;
  for (int v = 0; v < trace.height; ++v)
    for (int u = 0; u < trace.width; ++u)
      if (trace.layer_mask[static_cast<std::size_t>(v * trace.width + u)] != 0) {
        right[static_cast<std::size_t>(v)] = u;
        u_min = std::min(u_min, u);
        u_max = std::max(u_max, u);
      }
  REQUIRE(u_max > u_min + 100);

  SECTION("no depth beyond a column through the layer (beyond the sensor's range)") {
    SynthFrame f = full;
    const int cut = u_min + 2 * (u_max - u_min) / 3;
    for (int v = 0; v < cam.height; ++v)
      for (int u = cut; u < cam.width; ++u) f.frame.depth[static_cast<std::size_t>(v * cam.width + u)] = 0;
    rebuild_cloud(f);
    const LayerResult r = run_layer(f);
    REQUIRE(r.status == DetectionStatus::kOk);
    INFO("fraction " << r.diagnostics.unobserved_outline_fraction);
    CHECK(r.diagnostics.unobserved_outline_fraction > 0.15);
    CHECK(r.diagnostics.outline_along_invalid);
    CHECK(r.reason.find("without depth") != std::string::npos);
    // The whole pipeline keeps the warning with its result.
    const Detection d = detect(f.frame, {BoxFormat{0.315, 0.232, "315x232"}}, DetectionParams{});
    INFO("detection: " << d.message << " | " << d.ambiguity_reason);
    CHECK(d.outline_unobserved);
    CHECK(d.message.find("without depth") != std::string::npos);
    const Detection d_full = detect(full.frame, {BoxFormat{0.315, 0.232, "315x232"}}, DetectionParams{});
    CHECK_FALSE(d_full.outline_unobserved);
    CHECK(d_full.message.empty());
    LayerParams strict;
    strict.reject_unobserved = true;
    const LayerResult rejected = run_layer(f, strict);
    CHECK(rejected.status == DetectionStatus::kNoLayer);
    CHECK(rejected.reason.find("without depth") != std::string::npos);
  }
  SECTION("a strip 4 pixels wide without depth beside the layer, the lower layer seen beyond") {
    SynthFrame f = full;
    for (int v = 0; v < cam.height; ++v) {
      const int r0 = right[static_cast<std::size_t>(v)];
      if (r0 < 0) continue;
      for (int u = r0 + 1; u <= std::min(cam.width - 1, r0 + 4); ++u)
        f.frame.depth[static_cast<std::size_t>(v * cam.width + u)] = 0;
    }
    rebuild_cloud(f);
    const LayerResult r = run_layer(f);
    REQUIRE(r.status == DetectionStatus::kOk);
    INFO("fraction " << r.diagnostics.unobserved_outline_fraction);
    CHECK(r.diagnostics.unobserved_outline_fraction < 0.01);
    CHECK_FALSE(r.diagnostics.outline_along_invalid);
  }
}

TEST_CASE("detect() with a workspace gives the plain call's result, frame after frame") {
  const SynthScene scene = grid_layer(2, 2, 0.004, 1.0, true);
  SynthCamera vga;
  vga.tilt_deg = 10.0;
  vga.look_at = Eigen::Vector3d(0, 0, 1.0);
  SynthCamera small = vga;  // another size: the workspace must follow the intrinsics
  small.width = 320;
  small.height = 240;
  small.fx = small.fy = 285.0;
  const SynthFrame a = render_synthetic(scene, vga, SynthNoise{});
  const SynthFrame b = render_synthetic(scene, small, SynthNoise{});
  const std::vector<BoxFormat> formats{BoxFormat{0.315, 0.232, "315x232"}};
  DetectionWorkspace workspace;
  for (const SynthFrame* f : {&a, &b, &a}) {
    const Detection plain = detect(f->frame, formats, DetectionParams{});
    const Detection reused = detect(f->frame, formats, DetectionParams{}, workspace);
    REQUIRE(plain.status == DetectionStatus::kOk);
    CHECK(workspace.cloud.width == f->frame.intrinsics.width);
    CHECK(workspace.rays.matches(f->frame.intrinsics));
    CHECK(reused.status == plain.status);
    CHECK(reused.message == plain.message);
    CHECK(reused.plane_camera.d == plain.plane_camera.d);
    REQUIRE(reused.layer.polygons.size() == plain.layer.polygons.size());
    for (std::size_t i = 0; i < plain.layer.polygons.size(); ++i)
      CHECK(reused.layer.polygons[i].outer == plain.layer.polygons[i].outer);
    REQUIRE(reused.boxes.size() == plain.boxes.size());
    for (std::size_t i = 0; i < plain.boxes.size(); ++i) CHECK(reused.boxes[i].center == plain.boxes[i].center);
  }
  // The old signature still reuses a caller's ray table.
  RayTable rays;
  const Detection with_rays = detect(a.frame, formats, DetectionParams{}, &rays);
  CHECK(with_rays.status == DetectionStatus::kOk);
  CHECK(rays.matches(a.frame.intrinsics));
}

TEST_CASE("simplify: a small rotated box at a coarse pitch keeps its right-angled corners") {
  // A 230 x 300 mm box at 16 mm pixels (o3d303 binned at 2.5 m): about 14 x 19 pixels. The
  // polygon from Douglas-Peucker and per-edge fits blunts a corner here (a short diagonal edge,
  // or an edge laid along a pixel run); a box's corners are right angles and must come back.
  const double pitch = 0.016, half_l = 0.15, half_s = 0.115;
  for (const double yaw : {0.35, 0.95, 1.35}) {  // blunted before rectangles at 0.95 and 1.35
    const Eigen::Rotation2Dd R(yaw);
    const Eigen::Vector2d offset(0.003, -0.005);  // not centred on a pixel
    auto inside = [&](const Eigen::Vector2d& q) {
      const Eigen::Vector2d l = R.inverse() * (q - offset);
      return std::abs(l.x()) <= half_l && std::abs(l.y()) <= half_s;
    };
    const Rasterised r = rasterise(inside, pitch, 32, 32);
    REQUIRE(!r.ring.empty());
    const Ring2d poly = layer::simplify_ring(r.ring, r.samples, pitch, ContourParams{}, &r.origins);
    INFO("yaw " << yaw << ": " << describe(poly));
    REQUIRE(poly.size() == 4);
    for (const Eigen::Vector2d& c : {Eigen::Vector2d(-half_l, -half_s), Eigen::Vector2d(half_l, -half_s),
                                     Eigen::Vector2d(half_l, half_s), Eigen::Vector2d(-half_l, half_s)})
      CHECK(nearest(poly, offset + R * c) < 0.25 * pitch);
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d e0 = (poly[(k + 1) % 4] - poly[k]).normalized();
      const Eigen::Vector2d e1 = (poly[(k + 2) % 4] - poly[(k + 1) % 4]).normalized();
      CHECK(std::abs(e0.dot(e1)) < 0.02);
    }
  }
}

TEST_CASE("simplify: a corner cut by three pitches stays cut") {
  // The same box with one corner chamfered 48 mm along each side (3 pitches): a damaged or
  // chamfered box, not a raster artefact; the outline must not claim the missing corner.
  const double pitch = 0.016, half_l = 0.15, half_s = 0.115, cut = 3.0 * pitch;
  for (const double yaw : {0.35, 0.42, 1.1}) {
    const Eigen::Rotation2Dd R(yaw);
    auto inside = [&](const Eigen::Vector2d& q) {
      const Eigen::Vector2d l = R.inverse() * q;
      return std::abs(l.x()) <= half_l && std::abs(l.y()) <= half_s && (half_l - l.x()) + (half_s - l.y()) >= cut;
    };
    const Rasterised r = rasterise(inside, pitch, 32, 32);
    REQUIRE(!r.ring.empty());
    const Ring2d poly = layer::simplify_ring(r.ring, r.samples, pitch, ContourParams{}, &r.origins);
    INFO("yaw " << yaw << ": " << describe(poly));
    REQUIRE(poly.size() >= 5);
    const Eigen::Vector2d corner = R * Eigen::Vector2d(half_l, half_s);
    CHECK(nearest(poly, corner) > 1.5 * pitch);
    // The cut's two ends are corners of the outline.
    CHECK(nearest(poly, R * Eigen::Vector2d(half_l - cut, half_s)) < 0.5 * pitch);
    CHECK(nearest(poly, R * Eigen::Vector2d(half_l, half_s - cut)) < 0.5 * pitch);
    const double truth_area = 4.0 * half_l * half_s - 0.5 * cut * cut;
    CHECK(std::abs(signed_area(poly)) == Approx(truth_area).epsilon(0.02));
  }
}

TEST_CASE("simplify: a blunted corner of an L comes back, a chamfer of the same size stays") {
  // An L of two 300 x 230 mm boxes (not a rectangle) at 16 mm pixels. The ring through the
  // border pixel centres cuts one convex corner with a diagonal 3 pitches along each side. The
  // edge samples either follow the box edges into the corner (a right-angled corner the raster
  // blunted: it comes back) or follow the cut (a chamfered corner: it stays).
  const double pitch = 0.016, cut = 3.0 * pitch;
  const std::vector<Eigen::Vector2d> l_shape{{0.0, 0.0}, {0.6, 0.0}, {0.6, 0.23}, {0.3, 0.23}, {0.3, 0.46}, {0.0, 0.46}};
  const std::size_t blunted = 2;  // the corner (0.6, 0.23)
  const Eigen::Vector2d before = l_shape[blunted] + Eigen::Vector2d(0.0, -cut);
  const Eigen::Vector2d after = l_shape[blunted] + Eigen::Vector2d(-cut, 0.0);
  std::vector<Eigen::Vector2d> cut_outline;
  for (std::size_t k = 0; k < l_shape.size(); ++k) {
    if (k != blunted) {
      cut_outline.push_back(l_shape[k]);
      continue;
    }
    cut_outline.push_back(before);
    cut_outline.push_back(after);
  }
  // The ring (the border pixel centres, here without their staircase) follows the cut.
  std::vector<Eigen::Vector2d> ring = walk(cut_outline, pitch);
  for (const double yaw : {0.0, 0.3, 1.0}) {
    const Eigen::Rotation2Dd R(yaw);
    std::vector<Eigen::Vector2d> rotated_ring;
    for (const auto& p : ring) rotated_ring.push_back(R * p);
    SECTION("a blunted right-angled corner, yaw " + std::to_string(yaw)) {
      std::vector<Eigen::Vector2d> samples;
      for (const auto& p : walk(l_shape, 0.5 * pitch)) samples.push_back(R * p);
      const Ring2d poly = layer::simplify_ring(rotated_ring, samples, pitch, ContourParams{});
      INFO(describe(poly));
      CHECK(poly.size() == 6);
      for (const auto& c : l_shape) CHECK(nearest(poly, R * c) < 0.25 * pitch);
    }
    SECTION("a chamfered corner, yaw " + std::to_string(yaw)) {
      std::vector<Eigen::Vector2d> samples;
      for (const auto& p : walk(cut_outline, 0.5 * pitch)) samples.push_back(R * p);
      const Ring2d poly = layer::simplify_ring(rotated_ring, samples, pitch, ContourParams{});
      INFO(describe(poly));
      CHECK(poly.size() == 7);
      CHECK(nearest(poly, R * l_shape[blunted]) > 1.5 * pitch);
      CHECK(nearest(poly, R * before) < 0.25 * pitch);
      CHECK(nearest(poly, R * after) < 0.25 * pitch);
    }
  }
}

TEST_CASE("simplify: a ragged stretch of short slanted lines does not turn the straight edges") {
  // A 900 x 600 mm layer at 5 mm pixels whose bottom side runs ragged for 555 mm: three teeth
  // of 50 mm rising at 30 degrees and 144 mm falling at 10 degrees (a narrow gap between two
  // pieces that a stereo camera smooths over cuts an outline so). Weighted by length, those
  // lines turn the ring's grid by about 0.8 degrees; weighted by how well each line's direction
  // is measured, the straight edges decide.
  const double pitch = 0.005;
  std::vector<Eigen::Vector2d> outline{{0.0, 0.0}, {0.15, 0.0}};
  for (int tooth = 0; tooth < 3; ++tooth) {
    const Eigen::Vector2d p = outline.back();
    const Eigen::Vector2d up = p + 0.05 * Eigen::Vector2d(std::cos(M_PI / 6), std::sin(M_PI / 6));
    outline.push_back(up);
    outline.push_back(up + 0.144 * Eigen::Vector2d(std::cos(M_PI / 18), -std::sin(M_PI / 18)));
  }
  outline.back().y() = 0.0;
  for (const Eigen::Vector2d& p :
       {Eigen::Vector2d(0.9, 0.0), Eigen::Vector2d(0.9, 0.6), Eigen::Vector2d(0.0, 0.6)})
    outline.push_back(p);
  for (const double yaw : {0.2, 0.7}) {
    const Eigen::Rotation2Dd R(yaw);
    std::vector<Eigen::Vector2d> ring, samples;
    for (const auto& p : walk(outline, pitch)) ring.push_back(R * p);
    for (const auto& p : walk(outline, 0.5 * pitch)) samples.push_back(R * p);
    const Ring2d poly = layer::simplify_ring(ring, samples, pitch, ContourParams{});
    INFO(describe(poly));
    // The edge along the top side (its middle nearest the side's middle) runs along it.
    const Eigen::Vector2d top_mid = R * Eigen::Vector2d(0.45, 0.6);
    std::size_t best = 0;
    double best_d = 1e9;
    for (std::size_t k = 0; k < poly.size(); ++k) {
      const double d = (0.5 * (poly[k] + poly[(k + 1) % poly.size()]) - top_mid).norm();
      if (d < best_d) best_d = d, best = k;
    }
    const Eigen::Vector2d dir = poly[(best + 1) % poly.size()] - poly[best];
    const double err_deg =
        std::abs(std::remainder(std::atan2(dir.y(), dir.x()) - yaw, M_PI / 2)) * 180.0 / M_PI;
    INFO("yaw " << yaw << ": the top edge is off by " << err_deg << " deg");
    CHECK(best_d < 0.05);
    CHECK(err_deg < 0.2);
  }
}
