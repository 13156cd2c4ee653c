// The layer stages alone.
#include <catch2/catch.hpp>

#include "layer_stages.hpp"
#include "synthetic_scene.hpp"

using namespace palletd;

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

using namespace palletd::testing;

namespace {

/// Points along a w x h rectangle's outline every `step` [m], CCW from the origin corner.
std::vector<Eigen::Vector2d> rectangle_outline(double w, double h, double step) {
  std::vector<Eigen::Vector2d> pts;
  for (double x = 0; x < w; x += step) pts.emplace_back(x, 0);
  for (double y = 0; y < h; y += step) pts.emplace_back(w, y);
  for (double x = w; x > 0; x -= step) pts.emplace_back(x, h);
  for (double y = h; y > 0; y -= step) pts.emplace_back(0, y);
  return pts;
}

/// A 3 x 3 grid layer rendered without noise, the camera `distance_m` from its look-at point at
/// the layer's height, tilted by `tilt_deg`: the tests add the noise they study.
SynthFrame quiet_grid_layer(double tilt_deg, double distance_m) {
  SynthCamera cam;
  cam.tilt_deg = tilt_deg;
  cam.distance_m = distance_m;
  cam.look_at = Eigen::Vector3d(0, 0, 1.0);
  SynthNoise quiet;
  quiet.sigma_m = 0.0;
  return render_synthetic(grid_layer(3, 3, 0.0, 1.0, true), cam, quiet);
}
}  // namespace

TEST_CASE("layer frame: orthonormal, z along the normal, origin on the plane") {
  Plane plane;
  plane.normal = Eigen::Vector3d(0.2, -0.3, -1.0).normalized();
  plane.d = 1.7;
  const Eigen::Isometry3d T = layer::layer_frame(plane, Eigen::Vector3d(0.1, 0.2, 1.5));
  CHECK((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  CHECK(T.linear().determinant() == Approx(1.0));
  CHECK((T.linear().col(2) - plane.normal).norm() < 1e-12);
  CHECK(std::abs(plane.signed_distance(T.translation())) < 1e-12);
  // x: the camera x axis projected onto the plane.
  CHECK(std::abs(T.linear().col(0).dot(plane.normal.cross(Eigen::Vector3d::UnitX()))) < 1e-12);
  CHECK(T.linear().col(0).x() > 0.9);
}

TEST_CASE("border of a mask: pixels with an 8-neighbour off the mask, image edge counts as off") {
  cv::Mat mask(20, 30, CV_8U, cv::Scalar(0));
  mask(cv::Rect(5, 5, 10, 8)).setTo(255);
  mask(cv::Rect(0, 15, 4, 5)).setTo(255);  // touches the image border
  const cv::Mat border = layer::border_of(mask);
  CHECK(cv::countNonZero(border) == 2 * (10 + 8) - 4 + 2 * (4 + 5) - 4);
  CHECK(border.at<std::uint8_t>(9, 9) == 0);    // interior
  CHECK(border.at<std::uint8_t>(5, 9) == 255);  // top row of the rectangle
  CHECK(border.at<std::uint8_t>(19, 0) == 255); // on the image edge
}

TEST_CASE("crust: shuffled border points come back as one ring around the outline") {
  const std::vector<Eigen::Vector2d> outline = rectangle_outline(0.3, 0.2, 0.003);
  std::vector<int> order(outline.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::mt19937 rng(3);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<Eigen::Vector2d> pts;
  std::vector<int> chain;
  std::normal_distribution<double> noise(0.0, 0.0005);
  // Noise vectors draw y before x, one draw per statement (argument evaluation order is
  // unspecified; this is the order gcc used when the cases were tuned).
  auto noise_xy = [&] {
    const double dy = noise(rng);
    const double dx = noise(rng);
    return Eigen::Vector2d(dx, dy);
  };
  for (const int i : order) {
    pts.push_back(outline[static_cast<std::size_t>(i)] + noise_xy());
    chain.push_back(i);
  }
  std::vector<std::pair<int, int>> edges;
  const std::vector<int> ring = layer::crust_ring(pts, chain, 0.008, &edges);
  CHECK_FALSE(edges.empty());
  REQUIRE(ring.size() >= outline.size() / 2);  // shortest paths may skip zig-zag points
  Ring2d poly;
  for (const int i : ring) poly.push_back(pts[static_cast<std::size_t>(i)]);
  CHECK(std::abs(signed_area(poly)) == Approx(0.3 * 0.2).epsilon(0.03));
  // Consecutive ring points are neighbours on the outline (no jumps across the rectangle).
  for (std::size_t k = 0; k < poly.size(); ++k) CHECK((poly[k] - poly[(k + 1) % poly.size()]).norm() < 0.008);
}

TEST_CASE("simplify: a noisy rotated rectangle becomes four corners within a millimetre") {
  const double yaw = 0.3;
  const Eigen::Rotation2Dd R(yaw);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.0015);
  std::vector<Eigen::Vector2d> ring, samples;
  auto noise_xy = [&] {  // y before x, one draw per statement (see the crust case)
    const double dy = noise(rng);
    const double dx = noise(rng);
    return Eigen::Vector2d(dx, dy);
  };
  for (const auto& p : rectangle_outline(0.4, 0.3, 0.003)) {
    ring.push_back(R * p + noise_xy());
    samples.push_back(R * p + noise_xy());
  }
  const Ring2d poly = layer::simplify_ring(ring, samples, 0.003, ContourParams{});
  std::string corners;
  for (const auto& c : poly) corners += "(" + std::to_string(c.x()) + ", " + std::to_string(c.y()) + ") ";
  INFO(corners);
  REQUIRE(poly.size() == 4);
  const std::vector<Eigen::Vector2d> truth{R * Eigen::Vector2d(0, 0), R * Eigen::Vector2d(0.4, 0),
                                           R * Eigen::Vector2d(0.4, 0.3), R * Eigen::Vector2d(0, 0.3)};
  for (const auto& t : truth) {
    double best = 1e9;
    for (const auto& c : poly) best = std::min(best, (c - t).norm());
    CHECK(best < 0.001);
  }
  // Snapped to one grid: corners orthogonal.
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d e0 = (poly[(k + 1) % 4] - poly[k]).normalized();
    const Eigen::Vector2d e1 = (poly[(k + 2) % 4] - poly[(k + 1) % 4]).normalized();
    CHECK(std::abs(e0.dot(e1)) < std::sin(0.1 * M_PI / 180.0));
  }
}

TEST_CASE("top plane: nearest large plane wins, a small stray in front does not") {
  SynthScene s = grid_layer(3, 3, 0.0, 1.0, true);
  SynthBox stray;  // a 6 x 6 cm thing 30 cm above the layer
  stray.long_m = 0.06;
  stray.short_m = 0.06;
  stray.center = Eigen::Vector2d(0.1, 0.05);
  stray.bottom_z_m = 1.25;
  stray.top_z_m = 1.3;
  s.boxes.push_back(stray);
  SynthCamera cam;
  cam.tilt_deg = 30.0;
  cam.look_at = Eigen::Vector3d(0, 0, 1.0);
  const SynthFrame f = render_synthetic(s, cam, SynthNoise{});
  const layer::TopPlane top = layer::find_top_plane(f.cloud, f.frame.intrinsics, PlaneParams{});
  REQUIRE(top.status == DetectionStatus::kOk);
  CHECK(std::abs(top.plane.d - f.top_plane_camera.d) < 0.003);
  CHECK(top.plane.normal.dot(f.top_plane_camera.normal) > std::cos(0.5 * M_PI / 180.0));
  CHECK(top.sigma_m < 0.004);
  // The RANSAC seed changes the samples drawn, not the plane found.
  for (const std::uint32_t seed : {1U, 2U, 99U}) {
    PlaneParams seeded;
    seeded.seed = seed;
    const layer::TopPlane other = layer::find_top_plane(f.cloud, f.frame.intrinsics, seeded);
    REQUIRE(other.status == DetectionStatus::kOk);
    CHECK(std::abs(other.plane.d - f.top_plane_camera.d) < 0.003);
  }
}

TEST_CASE("noise per depth: the band widens where the measured noise does") {
  // Depth noise growing with depth (as structured light's does with its square): a tilted view
  // spans about 0.6 m of depth over the layer, the measured sigma must follow it.
  SynthFrame f = quiet_grid_layer(30.0, 2.5);
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0.0F, 1.0F);
  for (auto& p : f.cloud.points) {
    if (!p.allFinite()) continue;
    const float sigma = 0.0015F * p.z() * p.z();  // 6 mm at 2 m, 13.5 mm at 3 m
    p *= 1.0F + sigma * g(rng) / p.z();          // along the ray
  }
  const layer::TopPlane top = layer::find_top_plane(f.cloud, f.frame.intrinsics, PlaneParams{});
  REQUIRE(top.status == DetectionStatus::kOk);
  REQUIRE(top.noise.bin_z_m.size() >= 2);
  const double z_near = top.noise.bin_z_m.front(), z_far = top.noise.bin_z_m.back();
  REQUIRE(z_far - z_near > 0.2);
  // Sigma along the normal ~ sigma along the ray x cos(view angle): compare ratios, not values.
  const double ratio = top.noise.sigma_at(z_far) / top.noise.sigma_at(z_near);
  const double expected = (z_far * z_far) / (z_near * z_near);
  CHECK(ratio == Approx(expected).epsilon(0.25));
  const layer::BandTable band(top.noise, 0.0);
  CHECK(band.at(static_cast<float>(z_far)) > band.at(static_cast<float>(z_near)));
  CHECK(band.max_m() <= layer::kMaxBand);
  CHECK(std::abs(top.plane.d - f.top_plane_camera.d) < 0.003);
}

TEST_CASE("noise per depth: a quantised sensor's band spans one of its depth steps") {
  // A Kinect-like camera 2.66 m above a level layer: its depth comes from a disparity measured
  // in sub-pixel steps, in levels about 20 mm apart at that range, and each pixel reports the
  // level nearest to its noisy depth. A bin's spread depends on where the plane falls between
  // two levels; the layer's pixels lie on both.
  SynthFrame f = quiet_grid_layer(0.0, 2.66);
  const Eigen::Vector3f n = f.top_plane_camera.normal.cast<float>();
  const auto d = static_cast<float>(f.top_plane_camera.d);
  std::vector<std::size_t> on_top;
  std::mt19937 rng(11);
  std::normal_distribution<float> g(0.0F, 0.008F);
  constexpr float kStep_m = 0.020F;
  for (std::size_t i = 0; i < f.cloud.points.size(); ++i) {
    Eigen::Vector3f& p = f.cloud.points[i];
    if (!p.allFinite()) continue;
    if (std::abs(n.dot(p) + d) < 0.001F) on_top.push_back(i);
    const float z = p.z() + g(rng);
    p *= std::round(z / kStep_m) * kStep_m / p.z();  // along the ray, to the nearest level
  }
  REQUIRE(on_top.size() > 10000);
  const layer::TopPlane top = layer::find_top_plane(f.cloud, f.frame.intrinsics, PlaneParams{});
  REQUIRE(top.status == DetectionStatus::kOk);
  const double z_m = top.centroid.z();
  CHECK(top.noise.step_at(z_m) == Approx(kStep_m).epsilon(0.2));
  const layer::BandTable band(top.noise, 0.0);
  const layer::LayerMask mask = layer::layer_mask(f.cloud, top.plane, band, PlaneParams{});
  std::size_t kept = 0;
  for (const std::size_t i : on_top) kept += mask.mask.data[i] != 0 ? 1 : 0;
  CHECK(static_cast<double>(kept) / static_cast<double>(on_top.size()) > 0.98);
}

namespace {

/// A 300 x 100 cloud seen straight down (camera +z is down, 5 mm pixels at 2 m): the left piece
/// (columns 10-59, around x = -0.575 m) at depth `left_z_m`, the right piece (columns 240-289,
/// around x = 0.575 m) at `right_z_m`, rows 10-89, each tilted by `slope` along x (depth grows
/// with x); their pixels in `mask`.
OrganizedCloud two_pieces(double left_z_m, double right_z_m, double slope, cv::Mat& mask) {
  OrganizedCloud cloud;
  cloud.width = 300;
  cloud.height = 100;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud.points.assign(300 * 100, Eigen::Vector3f(nan, nan, nan));
  mask = cv::Mat(100, 300, CV_8U, cv::Scalar(0));
  for (int v = 10; v < 90; ++v) {
    for (int u = 10; u < 290; ++u) {
      if (u >= 60 && u < 240) continue;
      const double x = 0.005 * (u - 150), z = (u < 60 ? left_z_m : right_z_m) + slope * x;
      cloud.points[static_cast<std::size_t>(v * 300 + u)] =
          Eigen::Vector3d(x, 0.005 * (v - 50), z).cast<float>();
      mask.at<std::uint8_t>(v, u) = 255;
    }
  }
  return cloud;
}

/// The plane through two points of the x-z section (the cloud's pieces are flat in y) [camera].
Plane plane_through_section(double x0, double z0, double x1, double z1) {
  Plane p;
  p.normal = Eigen::Vector3d(-(z1 - z0), 0.0, x1 - x0).normalized();
  if (p.normal.z() > 0.0) p.normal = -p.normal;  // towards the camera
  p.d = -p.normal.dot(Eigen::Vector3d(x0, 0.0, z0));
  return p;
}

}  // namespace

TEST_CASE("stage 3b: a plane laid across a deck and the floor beyond is refitted on the deck") {
  // A deck 144 mm above the floor (the right piece), and the plane a search laid through both.
  cv::Mat mask;
  const OrganizedCloud cloud = two_pieces(2.0, 2.144, 0.0, mask);
  const Plane across = plane_through_section(-0.575, 2.0, 0.575, 2.144);
  const Eigen::Vector3d up(0.0, 0.0, -1.0);
  PlaneParams params;
  const std::optional<layer::PieceLevel> level = layer::highest_piece_level(mask, cloud, across, up, params);
  REQUIRE(level);
  CHECK(level->step_m == Approx(0.144).margin(0.001));
  CHECK(level->plane.normal.dot(up) > std::cos(0.1 * M_PI / 180.0));
  CHECK(std::abs(level->plane.signed_distance(Eigen::Vector3d(-0.6, 0.0, 2.0))) < 1e-6);   // on the deck
  CHECK(std::abs(level->plane.signed_distance(Eigen::Vector3d(0.6, 0.0, 2.144))) > 0.14);  // the floor not
  // One level: nothing to refit.
  const OrganizedCloud flat = two_pieces(2.0, 2.0, 0.0, mask);
  CHECK_FALSE(layer::highest_piece_level(mask, flat, plane_through_section(-0.5, 2.0, 0.5, 2.0), up, params));
}

TEST_CASE("stage 3b: pieces of one level under a calibration a few degrees off stay on the refitted plane") {
  // The level tilted 4 degrees against the calibrated up: its pieces 1.15 m apart lie 80 mm
  // apart along up, the step between two levels.
  const double slope = std::tan(4.0 * M_PI / 180.0);
  cv::Mat mask;
  const OrganizedCloud cloud = two_pieces(2.0, 2.0, slope, mask);
  const Plane level_plane = plane_through_section(-0.5, 2.0 - slope * 0.5, 0.5, 2.0 + slope * 0.5);
  const Eigen::Vector3d up(0.0, 0.0, -1.0);
  PlaneParams params;
  const std::optional<layer::PieceLevel> refit =
      layer::highest_piece_level(mask, cloud, level_plane, up, params);
  REQUIRE(refit);
  CHECK(refit->step_m > 0.07);
  // The other piece lies on the plane refitted on the higher one: it stays in the layer.
  CHECK(std::abs(refit->plane.normal.dot(level_plane.normal)) > std::cos(0.05 * M_PI / 180.0));
  CHECK(std::abs(refit->plane.signed_distance(Eigen::Vector3d(0.6, 0.0, 2.0 + slope * 0.6))) < 1e-4);
  // Tilted past detection.plane.max_base_tilt_deg, the piece is no level: no refit.
  params.max_base_tilt_deg = 3.0;
  CHECK_FALSE(layer::highest_piece_level(mask, cloud, level_plane, up, params));
}
