#include "synthetic_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <opencv2/imgproc.hpp>

namespace palletd::testing {
namespace {

/// Ray (origin o, direction r) against a yawed cuboid; returns t of the entry or +inf.
double hit_box(const SynthBox& b, const Eigen::Vector3d& o, const Eigen::Vector3d& r) {
  const double c = std::cos(-b.yaw_rad), s = std::sin(-b.yaw_rad);
  const Eigen::Vector3d ol(c * (o.x() - b.center.x()) - s * (o.y() - b.center.y()),
                           s * (o.x() - b.center.x()) + c * (o.y() - b.center.y()), o.z());
  const Eigen::Vector3d rl(c * r.x() - s * r.y(), s * r.x() + c * r.y(), r.z());
  const Eigen::Vector3d lo(-b.long_m / 2, -b.short_m / 2, b.bottom_z_m), hi(b.long_m / 2, b.short_m / 2, b.top_z_m);
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (std::abs(rl(k)) < 1e-12) {
      if (ol(k) < lo(k) || ol(k) > hi(k)) return std::numeric_limits<double>::infinity();
      continue;
    }
    double ta = (lo(k) - ol(k)) / rl(k), tb = (hi(k) - ol(k)) / rl(k);
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0;
}

}  // namespace

std::vector<Eigen::Vector2d> SynthBox::corners() const {
  const Eigen::Vector2d ax(std::cos(yaw_rad), std::sin(yaw_rad)), ay(-ax.y(), ax.x());
  const Eigen::Vector2d a = ax * long_m / 2, b = ay * short_m / 2;
  return {center - a - b, center + a - b, center + a + b, center - a + b};
}

SynthFrame render_synthetic(const SynthScene& scene, const SynthCamera& cam, const SynthNoise& noise) {
  SynthFrame out;
  Intrinsics& K = out.frame.intrinsics;
  K.width = cam.width;
  K.height = cam.height;
  K.fx = cam.fx;
  K.fy = cam.fy;
  K.cx = (cam.width - 1) / 2.0;
  K.cy = (cam.height - 1) / 2.0;
  out.frame.depth_scale_m = 1e-4;
  out.frame.depth.assign(out.frame.pixel_count(), 0);

  const double tilt = cam.tilt_deg * M_PI / 180.0, az = cam.tilt_azimuth_deg * M_PI / 180.0;
  const Eigen::Vector3d forward(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az), -std::cos(tilt));
  const Eigen::Vector3d origin = cam.look_at - forward * cam.distance_m;
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - forward * forward.x();
  x.normalize();
  const double roll = cam.roll_deg * M_PI / 180.0;
  Eigen::Vector3d y = forward.cross(x);
  x = std::cos(roll) * x + std::sin(roll) * y;
  y = forward.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = forward;
  T.translation() = origin;
  out.T_world_camera = T;

  std::mt19937 rng(noise.seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::vector<double> z(out.frame.pixel_count(), 0.0);
  for (int v = 0; v < K.height; ++v) {
    for (int u = 0; u < K.width; ++u) {
      const Eigen::Vector3d rc((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const Eigen::Vector3d rw = T.linear() * rc;
      double t = std::numeric_limits<double>::infinity();
      if (scene.floor && rw.z() < -1e-9) t = -origin.z() / rw.z();
      for (const SynthBox& b : scene.boxes) t = std::min(t, hit_box(b, origin, rw));
      if (std::isfinite(t)) z[static_cast<std::size_t>(v * K.width + u)] = t;  // t is the Z depth
    }
  }
  // Flying pixels: a mixed depth at edges.
  std::vector<double> zf = z;
  for (int v = 0; v + 1 < K.height; ++v) {
    for (int u = 0; u + 1 < K.width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * K.width + u);
      for (const std::size_t j : {i + 1, i + static_cast<std::size_t>(K.width)}) {
        if (z[i] <= 0.0 || z[j] <= 0.0 || std::abs(z[i] - z[j]) < 0.03) continue;
        if (uni(rng) < noise.flying) {
          const double a = 0.2 + 0.6 * uni(rng);
          zf[z[i] > z[j] ? i : j] = a * z[i] + (1 - a) * z[j];
        }
      }
    }
  }
  for (std::size_t i = 0; i < zf.size(); ++i) {
    if (zf[i] <= 0.0) continue;
    const double zn = zf[i] + noise.sigma_m * gauss(rng);
    if (uni(rng) < noise.dropout) continue;
    out.frame.depth[i] = static_cast<std::uint16_t>(std::clamp(std::lround(zn / out.frame.depth_scale_m), 0L, 65535L));
  }
  rebuild_cloud(out);

  // Truth plane: world z = top_z, normal up, in the camera frame.
  const Eigen::Isometry3d T_camera_world = T.inverse();
  out.top_plane_camera.normal = T_camera_world.linear() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d p = T_camera_world * Eigen::Vector3d(0, 0, scene.top_z_m);
  out.top_plane_camera.d = -out.top_plane_camera.normal.dot(p);
  return out;
}

void rebuild_cloud(SynthFrame& f) {
  const RayTable rays(f.frame.intrinsics);
  to_organized_cloud(f.frame, rays, f.cloud);
}

SynthScene single_box(double long_m, double short_m, double yaw_rad, double top_z_m) {
  SynthBox b;
  b.long_m = long_m;
  b.short_m = short_m;
  b.yaw_rad = yaw_rad;
  b.top_z_m = top_z_m;
  SynthScene s;
  s.boxes.push_back(b);
  s.top = {0};
  s.top_z_m = top_z_m;
  return s;
}

SynthCamera camera_looking_at(double look_at_z_m, double tilt_deg, double tilt_azimuth_deg) {
  SynthCamera cam;
  cam.tilt_deg = tilt_deg;
  cam.tilt_azimuth_deg = tilt_azimuth_deg;
  cam.look_at = Eigen::Vector3d(0, 0, look_at_z_m);
  return cam;
}

SynthScene grid_layer(int nx, int ny, double gap_m, double top_z_m, bool with_lower_layer) {
  SynthScene s;
  const double l = 0.315, w = 0.232, h = 0.2;
  const double x0 = -(nx * l + (nx - 1) * gap_m) / 2 + l / 2, y0 = -(ny * w + (ny - 1) * gap_m) / 2 + w / 2;
  if (with_lower_layer) {
    SynthBox lower;
    lower.long_m = nx * l + (nx - 1) * gap_m;
    lower.short_m = ny * w + (ny - 1) * gap_m;
    lower.bottom_z_m = 0.0;
    lower.top_z_m = top_z_m - h;
    s.boxes.push_back(lower);
  }
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      SynthBox b;
      b.center = Eigen::Vector2d(x0 + i * (l + gap_m), y0 + j * (w + gap_m));
      b.bottom_z_m = top_z_m - h;
      b.top_z_m = top_z_m;
      s.top.push_back(s.boxes.size());
      s.boxes.push_back(b);
    }
  }
  s.top_z_m = top_z_m;
  return s;
}

std::vector<std::vector<Eigen::Vector2d>> truth_in_layer(const SynthScene& scene, const SynthFrame& frame,
                                                         const Eigen::Isometry3d& T_camera_layer) {
  const Eigen::Isometry3d T_layer_world = T_camera_layer.inverse() * frame.T_world_camera.inverse();
  std::vector<std::vector<Eigen::Vector2d>> out;
  for (const std::size_t i : scene.top) {
    std::vector<Eigen::Vector2d> quad;
    for (const auto& c : scene.boxes[i].corners())
      quad.push_back((T_layer_world * Eigen::Vector3d(c.x(), c.y(), scene.boxes[i].top_z_m)).head<2>());
    out.push_back(quad);
  }
  return out;
}

double polygon_iou(const std::vector<PolygonWithHoles>& polygons,
                   const std::vector<std::vector<Eigen::Vector2d>>& truth, double cell_m) {
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  auto grow = [&](const Eigen::Vector2d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& p : polygons)
    for (const auto& q : p.outer) grow(q);
  for (const auto& t : truth)
    for (const auto& q : t) grow(q);
  if (lo.x() > hi.x()) return 0.0;
  lo -= Eigen::Vector2d(0.01, 0.01);
  hi += Eigen::Vector2d(0.01, 0.01);
  const int w = static_cast<int>(std::ceil((hi.x() - lo.x()) / cell_m)), h = static_cast<int>(std::ceil((hi.y() - lo.y()) / cell_m));
  if (w <= 0 || h <= 0 || static_cast<long>(w) * h > 40'000'000L) return 0.0;
  // Sub-cell precision: fillPoly with 8 fractional bits.
  constexpr int kShift = 8;
  auto to_px = [&](const std::vector<Eigen::Vector2d>& ring) {
    std::vector<cv::Point> out;
    for (const auto& q : ring)
      out.emplace_back(static_cast<int>(std::lround((q.x() - lo.x()) / cell_m * (1 << kShift))),
                       static_cast<int>(std::lround((q.y() - lo.y()) / cell_m * (1 << kShift))));
    return out;
  };
  cv::Mat det(h, w, CV_8U, cv::Scalar(0)), tru(h, w, CV_8U, cv::Scalar(0));
  for (const auto& p : polygons) {
    cv::Mat one(h, w, CV_8U, cv::Scalar(0));
    cv::fillPoly(one, std::vector<std::vector<cv::Point>>{to_px(p.outer)}, cv::Scalar(255), cv::LINE_8, kShift);
    for (const auto& hole : p.holes)
      cv::fillPoly(one, std::vector<std::vector<cv::Point>>{to_px(hole)}, cv::Scalar(0), cv::LINE_8, kShift);
    cv::bitwise_or(det, one, det);
  }
  for (const auto& t : truth)
    cv::fillPoly(tru, std::vector<std::vector<cv::Point>>{to_px(t)}, cv::Scalar(255), cv::LINE_8, kShift);
  cv::Mat inter, uni;
  cv::bitwise_and(det, tru, inter);
  cv::bitwise_or(det, tru, uni);
  const double u = cv::countNonZero(uni);
  return u > 0 ? cv::countNonZero(inter) / u : 0.0;
}

}  // namespace palletd::testing
