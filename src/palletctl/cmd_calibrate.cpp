// palletctl calibrate: camera_to_base from touched points. The robot touches three or more points
// on the empty pallet (or any known plane) in view; for each, the integrator notes the robot's
// base-frame coordinates and the point's pixel (u, v) in a frame of that scene (or its camera-frame
// coordinates). The rigid transform camera -> base is the least-squares fit (Umeyama, no scaling).
//
// Camera coordinates of a pixel point come from the plane fitted to the depth around it,
// intersected with the pixel's viewing ray (sub-pixel, no single noisy depth value). With only three
// points the fit is exact, so the plane constraint is added: the plane's normal (camera side) must
// map onto the normal of the plane through the three base points.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "palletd/frames/frame_io.hpp"

namespace palletd {

namespace {

struct CalibrateArgs {
  std::string frame;
  std::string points_file;
  std::vector<std::string> points;
  std::string units = "mm";
  int window_px = 7;  ///< half size of the window the local plane is fitted in [px]
};

struct TouchedPoint {
  bool from_pixel = true;
  double u = 0.0, v = 0.0;                        ///< [px] when from_pixel
  Eigen::Vector3d camera = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Vector3d base = Eigen::Vector3d::Zero();    ///< [m]
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< local plane normal, camera frame (pixel points)
  std::string text;
};

/// "u v X Y Z" (pixel + base) or "x y z X Y Z" (camera + base); commas or blanks between numbers.
Expected<TouchedPoint> parse_point(const std::string& line, double unit_m) {
  std::string cleaned = line;
  std::replace(cleaned.begin(), cleaned.end(), ',', ' ');
  std::istringstream in(cleaned);
  std::vector<double> v;
  double x = 0.0;
  while (in >> x) v.push_back(x);
  if (!in.eof()) return Error{"not a number in point \"" + line + "\""};
  TouchedPoint p;
  p.text = line;
  if (v.size() == 5) {
    p.u = v[0], p.v = v[1];
    p.base = Eigen::Vector3d(v[2], v[3], v[4]) * unit_m;
  } else if (v.size() == 6) {
    p.from_pixel = false;
    p.camera = Eigen::Vector3d(v[0], v[1], v[2]) * unit_m;
    p.base = Eigen::Vector3d(v[3], v[4], v[5]) * unit_m;
  } else {
    return Error{"point \"" + line + "\" needs 5 numbers (u v X Y Z) or 6 (x y z X Y Z), has " +
                 std::to_string(v.size())};
  }
  return p;
}

/// Normalised image coordinates of a (sub-)pixel, undistorted when the frame has distortion.
Eigen::Vector2d normalised(const Intrinsics& in, double u, double v) {
  if (!in.distortion) return {(u - in.cx) / in.fx, (v - in.cy) / in.fy};
  const cv::Matx33d k(in.fx, 0, in.cx, 0, in.fy, in.cy, 0, 0, 1);
  std::vector<double> dist(in.distortion->begin(), in.distortion->end());
  std::vector<cv::Point2d> src{{u, v}}, dst;
  cv::undistortPoints(src, dst, k, dist);
  return {dst[0].x, dst[0].y};
}

/// Intersects the viewing ray of (u, v) with the plane fitted to the depth in a window around it.
Status locate(const Frame& frame, int window, TouchedPoint& p) {
  const Intrinsics& in = frame.intrinsics;
  const int cu = static_cast<int>(std::lround(p.u)), cv_ = static_cast<int>(std::lround(p.v));
  if (cu < 0 || cv_ < 0 || cu >= in.width || cv_ >= in.height)
    return Error{"pixel (" + std::to_string(p.u) + ", " + std::to_string(p.v) + ") is outside the frame"};
  std::vector<Eigen::Vector3d> pts;
  for (int v = std::max(0, cv_ - window); v <= std::min(in.height - 1, cv_ + window); ++v) {
    for (int u = std::max(0, cu - window); u <= std::min(in.width - 1, cu + window); ++u) {
      const double z = frame.depth[static_cast<std::size_t>(v) * static_cast<std::size_t>(in.width) +
                                   static_cast<std::size_t>(u)] * frame.depth_scale_m;
      if (z <= 0.0) continue;
      const Eigen::Vector2d n = normalised(in, u, v);
      pts.emplace_back(n.x() * z, n.y() * z, z);
    }
  }
  if (pts.size() < 6) return Error{"too few depth measurements around pixel (" + p.text + ")"};
  // Robust: keep the points within 2 cm of the median depth (drops a neighbouring edge or gap).
  std::vector<double> zs;
  for (const auto& q : pts) zs.push_back(q.z());
  std::nth_element(zs.begin(), zs.begin() + static_cast<std::ptrdiff_t>(zs.size() / 2), zs.end());
  const double median = zs[zs.size() / 2];
  std::vector<Eigen::Vector3d> kept;
  for (const auto& q : pts)
    if (std::abs(q.z() - median) < 0.02) kept.push_back(q);
  if (kept.size() < 6) return Error{"no flat surface around pixel (" + p.text + ")"};
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& q : kept) centroid += q;
  centroid /= static_cast<double>(kept.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& q : kept) cov += (q - centroid) * (q - centroid).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d normal = eig.eigenvectors().col(0);  // smallest eigenvalue
  if (normal.dot(centroid) > 0.0) normal = -normal;      // toward the camera
  const Eigen::Vector2d n = normalised(in, p.u, p.v);
  const Eigen::Vector3d ray(n.x(), n.y(), 1.0);
  const double denom = normal.dot(ray);
  if (std::abs(denom) < 1e-6) return Error{"the surface at pixel (" + p.text + ") is seen edge-on"};
  p.camera = ray * (normal.dot(centroid) / denom);
  p.normal = normal;
  return {};
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6f", std::abs(v) < 5e-7 ? 0.0 : v);
  return buf;
}

int run_calibrate(const CalibrateArgs& a) {
  const double unit_m = a.units == "m" ? 1.0 : 0.001;
  std::vector<std::string> lines = a.points;
  if (!a.points_file.empty()) {
    std::ifstream in(a.points_file);
    if (!in) {
      spdlog::error("cannot read the points file {}", a.points_file);
      return 1;
    }
    for (std::string line; std::getline(in, line);) {
      const auto hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      lines.push_back(line);
    }
  }
  std::vector<TouchedPoint> points;
  for (const auto& line : lines) {
    Expected<TouchedPoint> p = parse_point(line, unit_m);
    if (!p) {
      spdlog::error("{}", p.error());
      return 2;
    }
    points.push_back(*p);
  }
  if (points.size() < 3) {
    spdlog::error("calibration needs at least 3 touched points, got {}", points.size());
    return 2;
  }
  const bool any_pixel = std::any_of(points.begin(), points.end(), [](const TouchedPoint& p) { return p.from_pixel; });
  if (any_pixel) {
    if (a.frame.empty()) {
      spdlog::error("points given by pixel need --frame STEM (a frame of the scene the robot touched)");
      return 2;
    }
    Expected<Frame> frame = read_frame(a.frame);
    if (!frame) {
      spdlog::error("{}", frame.error());
      return 1;
    }
    for (auto& p : points) {
      if (!p.from_pixel) continue;
      if (Status s = locate(*frame, a.window_px, p); !s) {
        spdlog::error("{}", s.error());
        return 1;
      }
    }
  }

  // Point sets, camera frame -> base frame. With exactly three points the plane constraint adds a
  // fourth pair: the triangle's centroid moved 0.1 m along its normal in both frames (the camera
  // normal is the fitted surface's where known, oriented like the triangle's).
  std::vector<Eigen::Vector3d> src, dst;
  for (const auto& p : points) src.push_back(p.camera), dst.push_back(p.base);
  if (points.size() == 3) {
    const Eigen::Vector3d nc_tri = (src[1] - src[0]).cross(src[2] - src[0]);
    const Eigen::Vector3d nb_tri = (dst[1] - dst[0]).cross(dst[2] - dst[0]);
    if (nc_tri.norm() < 1e-6 || nb_tri.norm() < 1e-6) {
      spdlog::error("the three points are (nearly) on one line: touch points spread over the pallet");
      return 1;
    }
    Eigen::Vector3d nc = nc_tri.normalized();
    Eigen::Vector3d surface = Eigen::Vector3d::Zero();
    for (const auto& p : points) surface += p.normal;
    if (surface.norm() > 0.5) nc = surface.normalized() * (surface.dot(nc_tri) >= 0.0 ? 1.0 : -1.0);
    const Eigen::Vector3d cc = (src[0] + src[1] + src[2]) / 3.0, cb = (dst[0] + dst[1] + dst[2]) / 3.0;
    src.push_back(cc + 0.1 * nc);
    dst.push_back(cb + 0.1 * nb_tri.normalized());
  }
  Eigen::Matrix3Xd S(3, static_cast<Eigen::Index>(src.size())), D(3, static_cast<Eigen::Index>(dst.size()));
  for (std::size_t i = 0; i < src.size(); ++i) {
    S.col(static_cast<Eigen::Index>(i)) = src[i];
    D.col(static_cast<Eigen::Index>(i)) = dst[i];
  }
  const Eigen::Matrix4d T = Eigen::umeyama(S, D, false);  // T_base_camera: camera -> base
  const Eigen::Isometry3d T_base_camera(T);

  std::printf("# palletctl calibrate: %zu touched points%s\n", points.size(),
              points.size() == 3 ? " (plane constraint added: with 3 points the residuals check little)" : "");
  std::printf("# %3s %28s %28s %12s\n", "pt", "camera x y z [m]", "base X Y Z [m]", "residual[mm]");
  double sum_sq = 0.0, worst = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d c = points[i].camera, b = points[i].base;
    const double r_mm = (T_base_camera * c - b).norm() * 1000.0;
    sum_sq += r_mm * r_mm;
    worst = std::max(worst, r_mm);
    std::printf("# %3zu %9.4f %9.4f %9.4f  %9.4f %9.4f %9.4f %12.2f\n", i + 1, c.x(), c.y(), c.z(), b.x(), b.y(),
                b.z(), r_mm);
  }
  const double rms = std::sqrt(sum_sq / static_cast<double>(points.size()));
  std::printf("# RMS residual %.2f mm, max %.2f mm\n", rms, worst);
  std::printf("# paste into the configuration (4x4 row-major, camera frame -> robot base frame, metres):\n");
  std::printf("%s", camera_to_base_yaml(T_base_camera).c_str());
  if (rms > 10.0)
    spdlog::warn("RMS residual {:.1f} mm is large: check the point list (units {}, pixel order u v)", rms,
                 a.units);
  return 0;
}

}  // namespace

std::string camera_to_base_yaml(const Eigen::Isometry3d& T_base_camera) {
  const Eigen::Matrix4d& T = T_base_camera.matrix();
  std::string yaml = "camera_to_base: [";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      yaml += number(T(r, c));
      if (r != 3 || c != 3) yaml += c == 3 ? ",   " : ", ";
    }
  }
  return yaml + "]\n";
}

void register_calibrate(CLI::App& app) {
  auto args = std::make_shared<CalibrateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate", "Compute camera_to_base from touched points (pixel or camera coordinates + robot base coordinates)");
  cmd->add_option("--frame", args->frame, "frame stem of the scene the robot touched (empty pallet or a plane)");
  cmd->add_option("--points", args->points_file,
                  "file, one point per line: 'u v X Y Z' (pixel + base) or 'x y z X Y Z' (camera + base); # comments")
      ->check(CLI::ExistingFile);
  cmd->add_option("--point", args->points, "one point, same format as a --points line (repeatable)");
  cmd->add_option("--units", args->units, "unit of the coordinates given (pixels stay pixels)")
      ->capture_default_str()
      ->check(CLI::IsMember({"mm", "m"}));
  cmd->add_option("--window", args->window_px, "half size of the depth window around a pixel point [px]")
      ->capture_default_str()
      ->check(CLI::Range(1, 50));
  cmd->callback([args] { throw CLI::RuntimeError(run_calibrate(*args)); });
}

}  // namespace palletd
