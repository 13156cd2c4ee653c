#include "palletd/core/frame.hpp"

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace palletd {

float Frame::depth_m(std::size_t i) const {
  const std::uint16_t raw = depth[i];
  if (raw == 0) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<float>(static_cast<double>(raw) * depth_scale_m);
}

RayTable::RayTable(const Intrinsics& intrinsics) : intrinsics_(intrinsics) {
  const auto w = static_cast<std::size_t>(intrinsics.width);
  const auto h = static_cast<std::size_t>(intrinsics.height);
  rays_.resize(w * h);
  if (!intrinsics.distortion) {
    for (std::size_t v = 0; v < h; ++v) {
      const auto y = static_cast<float>((static_cast<double>(v) - intrinsics.cy) / intrinsics.fy);
      for (std::size_t u = 0; u < w; ++u) {
        const auto x = static_cast<float>((static_cast<double>(u) - intrinsics.cx) / intrinsics.fx);
        rays_[v * w + u] = Eigen::Vector2f(x, y);
      }
    }
    return;
  }
  // Undistort every pixel centre once with OpenCV's iterative inverse of the plumb-bob model.
  std::vector<cv::Point2f> pixels;
  pixels.reserve(w * h);
  for (std::size_t v = 0; v < h; ++v)
    for (std::size_t u = 0; u < w; ++u)
      pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
  const cv::Matx33d k(intrinsics.fx, 0.0, intrinsics.cx, 0.0, intrinsics.fy, intrinsics.cy, 0.0, 0.0,
                      1.0);
  const auto& dist = *intrinsics.distortion;
  const cv::Matx<double, 1, 5> coeffs(dist[0], dist[1], dist[2], dist[3], dist[4]);
  std::vector<cv::Point2f> normalised;
  cv::undistortPoints(pixels, normalised, k, coeffs);
  for (std::size_t i = 0; i < normalised.size(); ++i)
    rays_[i] = Eigen::Vector2f(normalised[i].x, normalised[i].y);
}

bool RayTable::matches(const Intrinsics& other) const {
  return !rays_.empty() && other.width == intrinsics_.width && other.height == intrinsics_.height &&
         other.fx == intrinsics_.fx && other.fy == intrinsics_.fy && other.cx == intrinsics_.cx &&
         other.cy == intrinsics_.cy && other.distortion == intrinsics_.distortion;
}

void to_organized_cloud(const Frame& frame, const RayTable& rays, OrganizedCloud& cloud) {
  const std::size_t n = frame.pixel_count();
  cloud.width = frame.intrinsics.width;
  cloud.height = frame.intrinsics.height;
  cloud.points.resize(n);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto scale = static_cast<float>(frame.depth_scale_m);
  const std::uint16_t* depth = frame.depth.data();
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint16_t raw = depth[i];
    if (raw == 0) {
      cloud.points[i] = Eigen::Vector3f(nan, nan, nan);
      continue;
    }
    const float z = static_cast<float>(raw) * scale;
    const Eigen::Vector2f& r = rays.ray(i);
    cloud.points[i] = Eigen::Vector3f(r.x() * z, r.y() * z, z);
  }
}

}  // namespace palletd
