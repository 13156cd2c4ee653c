// extract_layer() end to end on synthetic frames: accuracy, holes, clusters, bad input.
#include <catch2/catch.hpp>

#include <cmath>

#include "palletd/detection/layer.hpp"
#include "palletd/detection/layer_debug.hpp"
#include "synthetic_scene.hpp"

using namespace palletd;
using namespace palletd::testing;

namespace {

constexpr double kBoxArea = 0.315 * 0.232;

LayerResult run(const SynthFrame& f, LayerTrace* trace = nullptr, LayerParams lp = {}) {
  return extract_layer(f.frame, f.cloud, PlaneParams{}, lp, ContourParams{}, 0.5 * kBoxArea, trace);
}

double normal_error_deg(const Plane& a, const Plane& b) {
  return std::acos(std::clamp(a.normal.dot(b.normal), -1.0, 1.0)) * 180.0 / M_PI;
}

double height_error_m(const LayerResult& r, const Plane& truth) {
  return std::abs(truth.signed_distance(r.T_camera_layer.translation()));
}

}  // namespace

TEST_CASE("full layer on a lower layer: plane and outline match the truth") {
  const SynthScene scene = grid_layer(3, 3, 0.0, 1.0, true);
  for (const double tilt : {0.0, 15.0, 30.0}) {
    const SynthCamera cam = camera_looking_at(1.0, tilt, 30.0);
    const SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
    const LayerResult r = run(f);
    INFO("tilt " << tilt << " reason " << r.reason);
    REQUIRE(r.status == DetectionStatus::kOk);
    CHECK(normal_error_deg(r.plane_camera, f.top_plane_camera) < 0.5);
    CHECK(height_error_m(r, f.top_plane_camera) < 0.003);
    REQUIRE(r.polygons.size() == 1);
    const double iou = polygon_iou(r.polygons, truth_in_layer(scene, f, r.T_camera_layer));
    CHECK(iou > 0.97);
    CHECK(signed_area(r.polygons[0].outer) > 0.0);
    CHECK_FALSE(r.diagnostics.touches_image_border);
  }
}

TEST_CASE("a few boxes on a full lower layer: the top is the boxes, not the dominant plane") {
  SynthScene scene = grid_layer(3, 3, 0.004, 1.0, true);
  // Keep two boxes of the top layer; the lower layer below dominates the image.
  SynthScene few;
  few.boxes.push_back(scene.boxes[0]);
  few.boxes.push_back(scene.boxes[1]);
  few.boxes.push_back(scene.boxes[9]);
  few.top = {1, 2};
  few.top_z_m = 1.0;
  const SynthCamera cam = camera_looking_at(1.0, 20.0);
  const SynthFrame f = render_synthetic(few, cam, SynthNoise{});
  const LayerResult r = run(f);
  INFO(r.reason);
  REQUIRE(r.status == DetectionStatus::kOk);
  CHECK(height_error_m(r, f.top_plane_camera) < 0.003);
  CHECK(r.polygons.size() == 2);  // two boxes far apart: two clusters
  CHECK(polygon_iou(r.polygons, truth_in_layer(few, f, r.T_camera_layer)) > 0.95);
}

TEST_CASE("a single box gives four near-orthogonal corners close to the truth") {
  const SynthScene s = single_box(0.315, 0.232, 0.4, 1.0);
  const SynthFrame f = render_synthetic(s, camera_looking_at(1.0, 25.0), SynthNoise{});
  const LayerResult r = run(f);
  REQUIRE(r.status == DetectionStatus::kOk);
  REQUIRE(r.polygons.size() == 1);
  const Ring2d& ring = r.polygons[0].outer;
  REQUIRE(ring.size() == 4);
  const auto truth = truth_in_layer(s, f, r.T_camera_layer)[0];
  for (const auto& c : ring) {
    double best = 1e9;
    for (const auto& t : truth) best = std::min(best, (c - t).norm());
    CHECK(best < 0.005);
  }
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d e0 = (ring[(k + 1) % 4] - ring[k]).normalized();
    const Eigen::Vector2d e1 = (ring[(k + 2) % 4] - ring[(k + 1) % 4]).normalized();
    CHECK(std::abs(e0.dot(e1)) < std::sin(1.0 * M_PI / 180.0));
  }
}

TEST_CASE("a hole 1.5 pixel pitches wide is found, clusters 30 mm apart stay apart") {
  // Seen from above: in oblique views the side walls inside a narrow gap lie within the band and
  // bridge it (the benchmark's sweep shows the tilted case).
  const SynthCamera cam = camera_looking_at(1.0, 0.0);
  // Largest pixel footprint on the layer (tilt stretches it by 1 / cos(tilt)).
  const double pitch_m = cam.distance_m / cam.fx / std::cos(cam.tilt_deg * M_PI / 180.0);
  // A ring of 8 boxes around a centre box shrunk so that a gap of 1.5 pitches surrounds it: the
  // gap is a hole of the outer component.
  SynthScene ring = grid_layer(3, 3, 0.0, 1.0, true);
  ring.boxes[5].long_m -= 2 * 1.5 * pitch_m;
  ring.boxes[5].short_m -= 2 * 1.5 * pitch_m;
  const SynthFrame fr = render_synthetic(ring, cam, SynthNoise{});
  const LayerResult rr = run(fr);
  REQUIRE(rr.status == DetectionStatus::kOk);
  std::size_t holes = 0;
  for (const auto& p : rr.polygons) holes += p.holes.size();
  CHECK(holes >= 1);
  CHECK(rr.polygons.size() == 2);  // the ring with its hole, and the centre box inside it
  for (const auto& p : rr.polygons)
    for (const auto& h : p.holes) CHECK(signed_area(h) < 0.0);
  CHECK(polygon_iou(rr.polygons, truth_in_layer(ring, fr, rr.T_camera_layer)) > 0.95);

  // Two boxes 30 mm apart, seen at a 30 deg tilt: two components.
  SynthCamera tilted = cam;
  tilted.tilt_deg = 30.0;
  tilted.tilt_azimuth_deg = 10.0;
  const SynthScene two = grid_layer(2, 1, 0.030, 1.0, true);
  const SynthFrame ft = render_synthetic(two, tilted, SynthNoise{});
  const LayerResult rt = run(ft);
  REQUIRE(rt.status == DetectionStatus::kOk);
  CHECK(rt.polygons.size() == 2);
}

TEST_CASE("a missing box inside the layer is one hole ring with the box's area") {
  // 3x3 layer of touching boxes, the centre box taken away: the lower layer shows through.
  const double gap = 0.0;
  SynthScene scene = grid_layer(3, 3, gap, 1.0, true);
  const std::size_t centre = 5;  // boxes[0] is the lower layer, then column-major 3x3
  const Eigen::Vector2d centre_xy = scene.boxes[centre].center;
  scene.boxes.erase(scene.boxes.begin() + static_cast<std::ptrdiff_t>(centre));
  scene.top.clear();
  for (std::size_t i = 1; i < scene.boxes.size(); ++i) scene.top.push_back(i);
  const double hole_area = (0.315 + 2 * gap) * (0.232 + 2 * gap);
  for (const double tilt : {0.0, 20.0}) {
    const SynthCamera cam = camera_looking_at(1.0, tilt, 35.0);
    const SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
    const LayerResult r = run(f);
    INFO("tilt " << tilt << " reason " << r.reason);
    REQUIRE(r.status == DetectionStatus::kOk);
    REQUIRE(r.polygons.size() == 1);
    REQUIRE(r.polygons[0].holes.size() == 1);
    const Ring2d& hole = r.polygons[0].holes[0];
    CHECK(signed_area(hole) < 0.0);  // holes run clockwise
    CHECK(std::abs(signed_area(hole)) == Approx(hole_area).epsilon(0.08));
    // Where the box was: the hole's vertex mean lies at the missing box's centre.
    const Eigen::Isometry3d T_layer_world = r.T_camera_layer.inverse() * f.T_world_camera.inverse();
    const Eigen::Vector2d expected = (T_layer_world * Eigen::Vector3d(centre_xy.x(), centre_xy.y(), 1.0)).head<2>();
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& q : hole) mean += q;
    mean /= static_cast<double>(hole.size());
    CHECK((mean - expected).norm() < 0.01);
    CHECK(polygon_iou(r.polygons, truth_in_layer(scene, f, r.T_camera_layer)) > 0.95);
  }
}

TEST_CASE("clusters at a tilt: apart when the gap shows more than the band below the top") {
  // Seen obliquely, the far box's side wall fills the gap; its top band-deep strip is within the
  // passthrough band, i.e. band x tan(tilt) of the gap look like layer. Where the rest of the gap
  // is at least two pixel footprints wide, the clusters must stay apart; where nothing of the gap
  // is deeper than the band, depth cannot separate them (the layout search splits such a cluster).
  // Azimuth 0, looking along the boxes' long axis: the gap's wall faces the camera.
  const SynthCamera cam = camera_looking_at(1.0, 20.0, 0.0);
  const double tan_tilt = std::tan(cam.tilt_deg * M_PI / 180.0);
  const double pitch_m = cam.distance_m / cam.fx / std::cos(cam.tilt_deg * M_PI / 180.0);
  // Band from a first look at the scene (the detector measures it from the data).
  const SynthFrame probe = render_synthetic(grid_layer(2, 1, 0.05, 1.0, true), cam, SynthNoise{});
  const LayerResult p = run(probe);
  REQUIRE(p.status == DetectionStatus::kOk);
  const double band = p.diagnostics.passthrough_tolerance_m;
  CHECK(band < 0.02);
  for (std::uint32_t seed = 1; seed <= 3; ++seed) {
    SynthNoise noise;
    noise.seed = seed;
    const double gap = band * tan_tilt + 2.0 * pitch_m;
    const SynthFrame f = render_synthetic(grid_layer(2, 1, gap, 1.0, true), cam, noise);
    const LayerResult r = run(f);
    INFO("seed " << seed << " gap " << gap * 1000 << " mm, band " << band * 1000 << " mm");
    REQUIRE(r.status == DetectionStatus::kOk);
    CHECK(r.polygons.size() == 2);
  }
}

TEST_CASE("dropouts inside faces make no border, flying pixels do not bend the outline") {
  const SynthScene s = single_box(0.6, 0.4, 0.0, 1.0);
  const SynthCamera cam = camera_looking_at(1.0, 10.0);
  SynthNoise noise;
  noise.dropout = 0.03;
  noise.flying = 0.8;
  const SynthFrame f = render_synthetic(s, cam, noise);
  LayerTrace trace;
  const LayerResult r = run(f, &trace);
  REQUIRE(r.status == DetectionStatus::kOk);
  REQUIRE(r.polygons.size() == 1);
  for (const auto& h : r.polygons[0].holes) {
    INFO("hole of " << h.size() << " vertices, area " << signed_area(h) << " m^2 at " << h[0].transpose());
    CHECK(false);
  }
  CHECK(r.polygons[0].outer.size() == 4);
  CHECK(r.diagnostics.filled_dropouts > 0);
  // Border pixels: about the outline's length in pixels (no false borders inside).
  const double perimeter_px = 2.0 * (0.6 + 0.4) / (cam.distance_m / cam.fx);
  CHECK(static_cast<double>(trace.border_pixels.size()) < 1.6 * perimeter_px);
  CHECK(polygon_iou(r.polygons, truth_in_layer(s, f, r.T_camera_layer)) > 0.98);
}

TEST_CASE("same frame, same result") {
  const SynthScene scene = grid_layer(2, 2, 0.0, 1.0, true);
  const SynthCamera cam = camera_looking_at(1.0, 12.0);
  const SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
  const LayerResult a = run(f), b = run(f);
  REQUIRE(a.status == DetectionStatus::kOk);
  REQUIRE(a.polygons.size() == b.polygons.size());
  CHECK(a.plane_camera.d == b.plane_camera.d);
  for (std::size_t i = 0; i < a.polygons.size(); ++i) {
    REQUIRE(a.polygons[i].outer.size() == b.polygons[i].outer.size());
    for (std::size_t k = 0; k < a.polygons[i].outer.size(); ++k) CHECK(a.polygons[i].outer[k] == b.polygons[i].outer[k]);
  }
}

TEST_CASE("bad input ends in a clear status, never a crash") {
  const SynthScene scene = grid_layer(2, 2, 0.0, 1.0, true);
  const SynthCamera cam = camera_looking_at(1.0);

  SECTION("every pixel invalid") {
    SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
    std::fill(f.frame.depth.begin(), f.frame.depth.end(), 0);
    rebuild_cloud(f);
    const LayerResult r = run(f);
    CHECK(r.status == DetectionStatus::kBadFrame);
    CHECK_FALSE(r.reason.empty());
  }
  SECTION("NaN and absurd depths") {
    SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
    for (std::size_t i = 0; i < f.cloud.points.size(); ++i) {
      if (i % 3 == 0) f.cloud.points[i] = Eigen::Vector3f(std::nanf(""), 0.0F, 1.0F);
      else f.cloud.points[i] *= 1000.0F;  // kilometres away
    }
    const LayerResult r = run(f);
    CHECK(r.status == DetectionStatus::kBadFrame);
    CHECK_FALSE(r.reason.empty());
  }
  SECTION("cloud and frame disagree") {
    SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
    f.cloud.points.resize(10);
    CHECK(run(f).status == DetectionStatus::kBadFrame);
  }
  SECTION("no plane facing the camera") {
    // A wall seen edge-on: the floor and boxes are gone, only a plane tilted 60 deg remains.
    SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
    for (int v = 0; v < f.cloud.height; ++v)
      for (int u = 0; u < f.cloud.width; ++u) {
        const double x = (u - f.frame.intrinsics.cx) / f.frame.intrinsics.fx;
        const double z = 2.0 / (1.0 + 1.7 * x);  // z = 2 - 1.7 X: normal 60 deg off the axis
        const std::size_t i = static_cast<std::size_t>(v * f.cloud.width + u);
        f.cloud.points[i] = z > 0.2 && z < 10.0 ? Eigen::Vector3f(static_cast<float>(x * z), static_cast<float>((v - f.frame.intrinsics.cy) / f.frame.intrinsics.fy * z), static_cast<float>(z))
                                                : Eigen::Vector3f(std::nanf(""), std::nanf(""), std::nanf(""));
      }
    const LayerResult r = run(f);
    CHECK(r.status == DetectionStatus::kNoPlane);
    CHECK_FALSE(r.reason.empty());
  }
  SECTION("a plane with too few points") {
    // One small box far away on no floor: its top is below the minimum plane area.
    SynthScene tiny = single_box(0.08, 0.08, 0.0, 1.0);
    tiny.floor = false;
    const SynthFrame f = render_synthetic(tiny, cam, SynthNoise{});
    const LayerResult r = run(f);
    CHECK(r.status != DetectionStatus::kOk);
    CHECK_FALSE(r.reason.empty());
  }
  SECTION("layer touching the image border") {
    const SynthScene big = grid_layer(3, 3, 0.0, 1.0, true);
    SynthCamera close = cam;
    close.distance_m = 0.8;  // the 3x3 layer (0.95 x 0.7 m) overfills the view
    const SynthFrame f = render_synthetic(big, close, SynthNoise{});
    const LayerResult r = run(f);
    REQUIRE(r.status == DetectionStatus::kOk);
    CHECK(r.diagnostics.touches_image_border);
    CHECK_FALSE(r.reason.empty());
    LayerParams strict;
    strict.reject_clipped = true;
    const LayerResult s = run(f, nullptr, strict);
    CHECK(s.status == DetectionStatus::kNoLayer);
    CHECK_FALSE(s.reason.empty());
  }
  SECTION("components smaller than the minimum are dropped") {
    SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
    const LayerResult r = extract_layer(f.frame, f.cloud, PlaneParams{}, LayerParams{}, ContourParams{}, 10.0);
    CHECK(r.status == DetectionStatus::kNoLayer);
    CHECK(r.diagnostics.dropped_components >= 1);
  }
}

TEST_CASE("debug pictures: one per stage, frame sized, with something drawn") {
  const SynthScene scene = grid_layer(2, 2, 0.0, 1.0, true);
  const SynthCamera cam = camera_looking_at(1.0);
  const SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
  LayerTrace trace;
  const LayerResult r = run(f, &trace);
  REQUIRE(r.status == DetectionStatus::kOk);
  const auto images = render_layer_debug_images(f.frame, r, trace);
  REQUIRE(images.size() == 4);
  CHECK(images[0].first == "layer_mask");
  CHECK(images[3].first == "rings");
  CHECK_FALSE(trace.crust_edges.empty());
  for (const auto& [name, img] : images) {
    CHECK(img.type() == CV_8UC3);
    CHECK(img.cols == f.frame.intrinsics.width);
    CHECK(img.rows == f.frame.intrinsics.height);
  }
  // The rings picture differs from the plain depth picture of an empty trace.
  const auto plain = render_layer_debug_images(f.frame, r, LayerTrace{});
  CHECK(cv::norm(images[1].second, plain[1].second, cv::NORM_L1) > 0.0);
}
