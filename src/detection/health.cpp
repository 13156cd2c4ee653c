// Cell health figures of one frame (health.hpp).
#include "palletd/detection/health.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "palletd/detection/detection.hpp"

namespace palletd {

namespace {

/// Nearer than this, a corner of the region of interest is behind or at the camera: its image is
/// unbounded and the whole view counts [m].
constexpr double kMinCornerDepthM = 0.05;
/// Mixed pixels: the jump across a pixel runs within this angle of its viewing ray (a real face
/// seen obliquely makes a larger one: 20 deg and more at the image's edge) [deg].
constexpr double kVeilAngleDeg = 10.0;
/// A mixed pixel lies this far from both neighbours at least, beyond three noise sigmas [m].
constexpr double kMixedMarginM = 0.005;
/// Width of the ring outside the layer where mixed pixels are counted [px].
constexpr int kRingPx = 2;

/// 255 where a pixel's viewing ray crosses the region of interest (pinhole image of its eight
/// corners' convex hull); the whole image without a region or when it reaches behind the camera.
cv::Mat roi_pixel_mask(const Frame& frame, const RegionOfInterest* roi) {
  const Intrinsics& in = frame.intrinsics;
  cv::Mat mask(in.height, in.width, CV_8U, cv::Scalar(255));
  const bool in_base = roi != nullptr && roi->frame == RegionOfInterest::Frame::kBase;
  if (roi == nullptr || (in_base && !frame.T_base_camera)) return mask;
  const Eigen::Isometry3d T_camera_roi =
      in_base ? frame.T_base_camera->inverse() : Eigen::Isometry3d::Identity();
  std::vector<cv::Point> corners;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner((i & 1) != 0 ? roi->max_m.x() : roi->min_m.x(),
                                 (i & 2) != 0 ? roi->max_m.y() : roi->min_m.y(),
                                 (i & 4) != 0 ? roi->max_m.z() : roi->min_m.z());
    const Eigen::Vector3d p = T_camera_roi * corner;
    if (!(p.z() > kMinCornerDepthM) || !p.allFinite()) return mask;
    const double u = in.fx * p.x() / p.z() + in.cx, v = in.fy * p.y() / p.z() + in.cy;
    corners.emplace_back(static_cast<int>(std::lround(std::clamp(u, -1e6, 1e6))),
                         static_cast<int>(std::lround(std::clamp(v, -1e6, 1e6))));
  }
  std::vector<cv::Point> hull;
  cv::convexHull(corners, hull);
  mask.setTo(0);
  cv::fillConvexPoly(mask, hull, cv::Scalar(255));
  return mask;
}

/// Shares of pixels without depth and with saturated intensity among the region's pixels.
void count_pixels(const Frame& frame, const cv::Mat& roi_mask, FrameHealth& health) {
  const Intrinsics& in = frame.intrinsics;
  const auto count_in_roi = [&](const cv::Mat& hits) {
    cv::Mat inside;
    cv::bitwise_and(hits, roi_mask, inside);
    return static_cast<std::size_t>(cv::countNonZero(inside));
  };
  health.roi_pixels = static_cast<std::size_t>(cv::countNonZero(roi_mask));
  if (health.roi_pixels == 0) return;
  const double n = static_cast<double>(health.roi_pixels);
  const cv::Mat depth(in.height, in.width, CV_16U, const_cast<std::uint16_t*>(frame.depth.data()));
  health.invalid_fraction = static_cast<double>(count_in_roi(depth == 0)) / n;
  if (!frame.has_intensity() || frame.intensity.size() != frame.depth.size()) return;
  const double full_scale = frame.intensity_bits == 8 ? 255.0 : 65535.0;
  const cv::Mat intensity(in.height, in.width, CV_16U, const_cast<std::uint16_t*>(frame.intensity.data()));
  health.saturated_fraction = static_cast<double>(count_in_roi(intensity >= full_scale)) / n;
}

/// True when pixel (u, v) at depth z lies between its neighbours kRingPx away along one axis, on a
/// jump that runs along the viewing ray: a mixed pixel, part foreground, part background.
bool is_mixed(const Frame& frame, int u, int v, double z_m, double margin_m) {
  const Intrinsics& in = frame.intrinsics;
  static const double veil = 1.0 / std::tan(kVeilAngleDeg * M_PI / 180.0);
  const std::array<std::array<int, 2>, 2> axes{{{1, 0}, {0, 1}}};
  for (const auto& [du, dv] : axes) {
    const int u0 = u - du * kRingPx, v0 = v - dv * kRingPx, u1 = u + du * kRingPx, v1 = v + dv * kRingPx;
    if (u0 < 0 || v0 < 0 || u1 >= in.width || v1 >= in.height) continue;
    const float za = frame.depth_m(static_cast<std::size_t>(v0) * in.width + u0);
    const float zb = frame.depth_m(static_cast<std::size_t>(v1) * in.width + u1);
    if (!std::isfinite(za) || !std::isfinite(zb)) continue;
    const double near_m = std::min(za, zb), far_m = std::max(za, zb);
    const double lateral_m = 2.0 * kRingPx * z_m / (du != 0 ? in.fx : in.fy);
    if (z_m - near_m > margin_m && far_m - z_m > margin_m && far_m - near_m > veil * lateral_m) return true;
  }
  return false;
}

/// Share of mixed pixels among the pixels with depth in the ring just outside the layer.
std::optional<double> flying_fraction(const Frame& frame, const cv::Mat& roi_mask, const LayerResult& layer) {
  if (layer.point_pixels.empty()) return std::nullopt;
  const Intrinsics& in = frame.intrinsics;
  cv::Mat full_mask = cv::Mat::zeros(in.height, in.width, CV_8U);
  for (const std::int32_t i : layer.point_pixels) full_mask.data[i] = 255;
  // The ring lies within kRingPx of the layer's bounding rectangle.
  const cv::Rect tight = cv::boundingRect(full_mask);
  const cv::Rect box =
      cv::Rect(tight.x - kRingPx, tight.y - kRingPx, tight.width + 2 * kRingPx, tight.height + 2 * kRingPx) &
      cv::Rect(0, 0, in.width, in.height);
  const cv::Mat layer_mask = full_mask(box);
  cv::Mat ring;
  cv::dilate(layer_mask, ring,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * kRingPx + 1, 2 * kRingPx + 1)));
  ring.setTo(0, layer_mask);
  const double margin_m = std::max(kMixedMarginM, 3.0 * layer.diagnostics.plane_sigma_m);
  std::size_t seen = 0, mixed = 0;
  for (int y = 0; y < box.height; ++y) {
    const std::uint8_t* r = ring.ptr<std::uint8_t>(y);
    const std::uint8_t* m = roi_mask.ptr<std::uint8_t>(y + box.y) + box.x;
    for (int x = 0; x < box.width; ++x) {
      if (r[x] == 0 || m[x] == 0) continue;
      const int u = x + box.x, v = y + box.y;
      const float z_m = frame.depth_m(static_cast<std::size_t>(v) * in.width + u);
      if (!std::isfinite(z_m)) continue;
      ++seen;
      if (is_mixed(frame, u, v, z_m, margin_m)) ++mixed;
    }
  }
  if (seen == 0) return std::nullopt;
  return static_cast<double>(mixed) / static_cast<double>(seen);
}

}  // namespace

double DepthNoiseModel::sigma_mm(double range_m) const {
  return sigma_mm_at_1m * std::pow(std::max(range_m, 0.0), exponent);
}

FrameHealth measure_frame_health(const Frame& frame, const RegionOfInterest* roi, const LayerResult& layer,
                                 const DepthNoiseModel& noise_model) {
  FrameHealth health;
  if (frame.depth.size() != frame.pixel_count() || frame.pixel_count() == 0) return health;
  health.measured = true;
  const cv::Mat roi_mask = roi_pixel_mask(frame, roi);
  count_pixels(frame, roi_mask, health);
  const double sigma_m = layer.diagnostics.plane_sigma_m;
  if (layer.diagnostics.plane_inliers == 0 || !(sigma_m > 0.0)) return health;
  health.flying_fraction = flying_fraction(frame, roi_mask, layer);
  health.plane_noise_mm = sigma_m * 1000.0;
  // Range where the optical axis meets the plane (n . (0, 0, z) + d = 0).
  const Plane& plane = layer.plane_camera;
  const double range_m = std::abs(plane.d) / std::max(std::abs(plane.normal.z()), 0.5);
  if (noise_model.enabled()) {
    health.model_noise_mm = noise_model.sigma_mm(range_m);
    health.noise_ratio = *health.plane_noise_mm / *health.model_noise_mm;
  }
  return health;
}

}  // namespace palletd
