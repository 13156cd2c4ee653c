// Organized PCD/PLY clouds as depth frames (see cloud_frame.hpp).
#include "replay/cloud_frame.hpp"

#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

namespace palletd {

namespace {

std::string lower_extension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos) return {};
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

constexpr double kUnitM = 1e-4;  ///< 0.1 mm depth units

/// Least squares fit of p = f a + c; returns the RMS residual [px].
double fit_axis(const std::vector<Eigen::Vector2d>& samples, double& f, double& c) {
  Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
  Eigen::Vector2d atb = Eigen::Vector2d::Zero();
  for (const auto& s : samples) {  // s = (a, p)
    const Eigen::Vector2d row(s.x(), 1.0);
    ata += row * row.transpose();
    atb += row * s.y();
  }
  const Eigen::Vector2d x = ata.ldlt().solve(atb);
  f = x(0);
  c = x(1);
  double sq = 0.0;
  for (const auto& s : samples) sq += (f * s.x() + c - s.y()) * (f * s.x() + c - s.y());
  return std::sqrt(sq / static_cast<double>(samples.size()));
}

}  // namespace

bool is_cloud_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".pcd" || ext == ".ply";
}

Expected<Frame> read_cloud_frame(const std::string& path) {
  pcl::PCLPointCloud2 blob;
  const std::string ext = lower_extension(path);
  int rc = -1;
  if (ext == ".pcd") {
    pcl::PCDReader reader;
    rc = reader.read(path, blob);
  } else if (ext == ".ply") {
    pcl::PLYReader reader;
    rc = reader.read(path, blob);
  } else {
    return Error{path + ": not a .pcd or .ply file"};
  }
  if (rc < 0) return Error{path + ": PCL cannot read the cloud (code " + std::to_string(rc) + ")"};
  if (blob.height <= 1 || blob.width == 0) {
    return Error{path + ": the cloud is not organized (" + std::to_string(blob.width) + "x" +
                 std::to_string(blob.height) + "); replay needs one point per pixel"};
  }
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl::fromPCLPointCloud2(blob, xyz);
  const bool has_intensity = std::any_of(blob.fields.begin(), blob.fields.end(),
                                         [](const pcl::PCLPointField& f) { return f.name == "intensity"; });
  pcl::PointCloud<pcl::PointXYZI> xyzi;
  if (has_intensity) pcl::fromPCLPointCloud2(blob, xyzi);

  Frame frame;
  const int width = static_cast<int>(xyz.width);
  const int height = static_cast<int>(xyz.height);
  frame.intrinsics.width = width;
  frame.intrinsics.height = height;
  frame.depth_scale_m = kUnitM;
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  frame.depth.assign(n, 0);
  std::vector<Eigen::Vector2d> us, vs;
  us.reserve(n);
  vs.reserve(n);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * static_cast<std::size_t>(width) + static_cast<std::size_t>(u);
      const pcl::PointXYZ& p = xyz.points[i];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || p.z <= 0.0f) continue;
      const double z = static_cast<double>(p.z);
      frame.depth[i] = static_cast<std::uint16_t>(std::min(std::round(z / kUnitM), 65535.0));
      us.emplace_back(static_cast<double>(p.x) / z, static_cast<double>(u));
      vs.emplace_back(static_cast<double>(p.y) / z, static_cast<double>(v));
    }
  }
  if (us.size() < 3) return Error{path + ": fewer than 3 valid points; cannot estimate intrinsics"};
  Intrinsics& k = frame.intrinsics;
  const double rms_u = fit_axis(us, k.fx, k.cx);
  const double rms_v = fit_axis(vs, k.fy, k.cy);
  if (!(k.fx > 0.0 && k.fy > 0.0) || !(rms_u <= 0.5 && rms_v <= 0.5)) {
    return Error{path + ": the points do not follow a pinhole projection (fx " + std::to_string(k.fx) + ", fy " +
                 std::to_string(k.fy) + ", RMS " + std::to_string(std::max(rms_u, rms_v)) + " px)"};
  }
  if (has_intensity) {
    frame.intensity.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const float value = xyzi.points[i].intensity;
      frame.intensity[i] =
          std::isfinite(value) ? static_cast<std::uint16_t>(std::clamp(std::round(value), 0.0f, 65535.0f)) : 0;
    }
    frame.intensity_bits = 16;
  }
  return frame;
}

}  // namespace palletd
