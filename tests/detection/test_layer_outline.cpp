// Outline placement at a coarse pixel pitch, the "outline along invalid pixels" diagnostic, and
// detect() with a caller-owned workspace.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"
#include "palletd/detection.hpp"
#include "palletd/layer.hpp"
#include "synthetic_scene.hpp"

using namespace palletd;
using namespace palletd::testing;

namespace {

constexpr double kBoxArea = 0.315 * 0.232;

LayerResult run(const SynthFrame& f, LayerParams lp = {}, LayerTrace* trace = nullptr) {
  return extract_layer(f.frame, f.cloud, PlaneParams{}, lp, ContourParams{}, 0.5 * kBoxArea, trace);
}

double nearest(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& q) {
  double best = 1e9;
  for (const auto& p : points) best = std::min(best, (p - q).norm());
  return best;
}

double segment_distance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& q) {
  const Eigen::Vector2d d = b - a;
  const double t = std::clamp((q - a).dot(d) / std::max(d.squaredNorm(), 1e-12), 0.0, 1.0);
  return (a + t * d - q).norm();
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
  const int w = 40, h = 24;
  auto centre = [&](int u, int v) { return Eigen::Vector2d((u - w / 2) * px, (v - h / 2) * py); };
  cv::Mat mask(h, w, CV_8U, cv::Scalar(0));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      if (inside(centre(u, v))) mask.at<std::uint8_t>(v, u) = 255;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  REQUIRE(contours.size() == 1);
  std::vector<Eigen::Vector2d> ring, samples, origins;
  static const int du[4] = {-1, 1, 0, 0};
  static const int dv[4] = {0, 0, -1, 1};
  cv::Mat seen(h, w, CV_8U, cv::Scalar(0));
  for (const cv::Point& p : contours[0]) {
    if (seen.at<std::uint8_t>(p) != 0) continue;
    seen.at<std::uint8_t>(p) = 1;
    const Eigen::Vector2d q = centre(p.x, p.y);
    ring.push_back(q);
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d o = centre(p.x + du[k], p.y + dv[k]);
      if (inside(o)) continue;
      double lo = 0.0, hi = 1.0;  // the edge crossing on q -> o, by bisection
      for (int it = 0; it < 40; ++it) {
        const double mid = 0.5 * (lo + hi);
        (inside(q + mid * (o - q)) ? lo : hi) = mid;
      }
      samples.push_back(q + lo * (o - q));
      origins.push_back(q);
    }
  }
  const Ring2d poly = layer::simplify_ring(ring, samples, py, ContourParams{}, &origins);
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
  SynthScene s;
  SynthBox b;
  b.long_m = 0.6;
  b.short_m = 0.4;
  b.yaw_rad = 0.5;
  b.top_z_m = 1.0;
  s.boxes.push_back(b);
  s.top = {0};
  s.top_z_m = 1.0;
  SynthNoise quiet;
  quiet.sigma_m = 0.0;
  quiet.dropout = 0.0;
  quiet.flying = 0.0;
  for (const double azimuth : {0.0, 90.0, 200.0}) {
    SynthCamera cam;
    cam.width = 176;
    cam.height = 132;
    cam.fx = cam.fy = 152.0;
    cam.distance_m = 2.5;
    cam.tilt_deg = 25.0;
    cam.tilt_azimuth_deg = azimuth;
    cam.look_at = Eigen::Vector3d(0, 0, 1.0);
    const SynthFrame f = render_synthetic(s, cam, quiet);
    const LayerResult r = run(f);
    INFO("azimuth " << azimuth << " reason " << r.reason);
    REQUIRE(r.status == DetectionStatus::ok);
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
  SynthCamera cam;
  cam.look_at = Eigen::Vector3d(0, 0, 1.0);
  const SynthFrame full = render_synthetic(scene, cam, SynthNoise{});
  LayerTrace trace;
  const LayerResult observed = run(full, {}, &trace);
  REQUIRE(observed.status == DetectionStatus::ok);
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
    const LayerResult r = run(f);
    REQUIRE(r.status == DetectionStatus::ok);
    INFO("fraction " << r.diagnostics.unobserved_outline_fraction);
    CHECK(r.diagnostics.unobserved_outline_fraction > 0.15);
    CHECK(r.diagnostics.outline_along_invalid);
    CHECK(r.reason.find("without depth") != std::string::npos);
    LayerParams strict;
    strict.reject_unobserved = true;
    const LayerResult rejected = run(f, strict);
    CHECK(rejected.status == DetectionStatus::no_layer);
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
    const LayerResult r = run(f);
    REQUIRE(r.status == DetectionStatus::ok);
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
    REQUIRE(plain.status == DetectionStatus::ok);
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
  CHECK(with_rays.status == DetectionStatus::ok);
  CHECK(rays.matches(a.frame.intrinsics));
}
