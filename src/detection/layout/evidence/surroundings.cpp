// The layer's surroundings as the camera saw them (LayerSurroundings): each pixel's viewing ray
// meets the plane at a layer-frame point; the pixel votes there for `level`, `below` or `unseen`.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "layer_raster.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

std::uint8_t LayerSurroundings::at_point(const Eigen::Vector2d& p_m) const {
  if (empty()) return kUnseen;
  const double fx = (p_m.x() - origin_m.x()) / cell_m, fy = (p_m.y() - origin_m.y()) / cell_m;
  if (!(fx >= 0 && fy >= 0 && fx < width && fy < height)) return kUnseen;
  return at(static_cast<int>(fx), static_cast<int>(fy));
}

bool LayerSurroundings::seen_within(const Eigen::Vector2d& p_m, const Eigen::Vector2d& dir,
                                    double reach_m) const {
  for (double u = 0.0; u <= reach_m; u += 0.5 * cell_m) {
    if (at_point(p_m + u * dir) != kUnseen) return true;
  }
  return false;
}

LayerSurroundings build_layer_surroundings(const Frame& frame, const OrganizedCloud& cloud,
                                           const LayerResult& layer, double reach_m) {
  LayerSurroundings out;
  const Intrinsics& in = frame.intrinsics;
  if (layer.status != DetectionStatus::kOk || layer.polygons.empty() || !in.valid() ||
      cloud.width != in.width || cloud.height != in.height || cloud.points.size() != frame.pixel_count() ||
      !(reach_m >= 0.0)) {
    return out;
  }
  const Plane& plane = layer.plane_camera;
  const auto geo = layout_detail::layer_raster_geometry(
      in, layer, std::clamp(layout_detail::layer_pixel_pitch_m(in, layer), 0.004, 0.02), reach_m);
  if (!geo) return out;
  out.cell_m = geo->cell_m;
  out.origin_m = geo->origin_m;
  out.width = geo->width;
  out.height = geo->height;

  // At the layer's level within the band: boxes of the layer differ in height by millimetres,
  // a lower layer by a box height.
  const double band_m = std::max(0.015, layer.diagnostics.passthrough_tolerance_m);
  std::array<cv::Mat, 3> votes;
  for (auto& v : votes) v = cv::Mat::zeros(out.height, out.width, CV_32F);
  const layout_detail::PixelWindow window = layout_detail::pixels_on_raster(*geo, in);
  for (int v = window.v0; v < window.v1; ++v) {
    for (int u = window.u0; u < window.u1; ++u) {
      double fx = 0.0, fy = 0.0;
      if (!geo->cell_of(u, v, &fx, &fy)) continue;
      const Eigen::Vector3f& p = cloud.at(u, v);
      int label = LayerSurroundings::kUnseen;
      if (std::isfinite(p.x()) && std::isfinite(p.z())) {
        const double s = plane.signed_distance(p.cast<double>());  // + towards the camera
        if (s < -band_m) {
          label = LayerSurroundings::kBelow;
        } else if (s <= band_m) {
          label = LayerSurroundings::kLevel;
        }
      }
      votes[static_cast<std::size_t>(label)].at<float>(static_cast<int>(fy), static_cast<int>(fx)) += 1.f;
    }
  }
  // Cells no pixel fell into take their neighbours' votes; cells beyond the image stay unseen.
  std::array<cv::Mat, 3> near;
  for (std::size_t k = 0; k < 3; ++k)
    cv::boxFilter(votes[k], near[k], CV_32F, cv::Size(3, 3), cv::Point(-1, -1), false);
  out.label.assign(static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height),
                   LayerSurroundings::kUnseen);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      const bool own = votes[0].at<float>(y, x) + votes[1].at<float>(y, x) + votes[2].at<float>(y, x) > 0.f;
      const std::array<cv::Mat, 3>& src = own ? votes : near;
      const float n_unseen = src[0].at<float>(y, x), n_level = src[1].at<float>(y, x),
                  n_below = src[2].at<float>(y, x);
      // Seen lower wins a tie with unseen: a box is never completed into a spot seen empty.
      std::uint8_t label = LayerSurroundings::kUnseen;
      if (n_level > n_below && n_level > n_unseen) {
        label = LayerSurroundings::kLevel;
      } else if (n_below > 0.f && n_below >= n_unseen) {
        label = LayerSurroundings::kBelow;
      }
      out.label[static_cast<std::size_t>(y) * static_cast<std::size_t>(out.width) +
                static_cast<std::size_t>(x)] = label;
    }
  }
  return out;
}

std::vector<RimPixel> build_layer_rim(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                                      double min_drop_m) {
  std::vector<RimPixel> rim;
  const Intrinsics& in = frame.intrinsics;
  if (layer.status != DetectionStatus::kOk || layer.polygons.empty() || !in.valid() ||
      cloud.width != in.width || cloud.height != in.height || cloud.points.size() != frame.pixel_count()) {
    return rim;
  }
  const Plane& plane = layer.plane_camera;
  // Where a pixel's ray meets the plane (only the raster's homography is used; coarse cells keep
  // it within the raster size limit on any layer).
  const auto geo = layout_detail::layer_raster_geometry(in, layer, 0.02, 0.1);
  if (!geo) return rim;
  const double band_m = std::max(0.015, layer.diagnostics.passthrough_tolerance_m);
  // Depth below the plane per pixel [m]; NaN without depth.
  auto below = [&](int u, int v) {
    if (u < 0 || v < 0 || u >= in.width || v >= in.height) return std::numeric_limits<double>::quiet_NaN();
    const Eigen::Vector3f& p = cloud.at(u, v);
    if (!std::isfinite(p.x()) || !std::isfinite(p.z())) return std::numeric_limits<double>::quiet_NaN();
    return -plane.signed_distance(p.cast<double>());
  };
  // The layer's own pixels; only their 4-neighbours can be rim pixels.
  const auto width = static_cast<std::size_t>(in.width);
  std::vector<std::uint8_t> state(frame.pixel_count(), 0);  // 1 = layer, 2 = visited
  for (const std::int32_t i : layer.point_pixels) {
    if (i >= 0 && static_cast<std::size_t>(i) < state.size()) state[static_cast<std::size_t>(i)] = 1;
  }
  auto on_layer = [&](int u, int v) {
    return u >= 0 && v >= 0 && u < in.width && v < in.height &&
           state[static_cast<std::size_t>(v) * width + static_cast<std::size_t>(u)] == 1;
  };
  constexpr int kDirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (const std::int32_t i : layer.point_pixels) {
    if (i < 0 || static_cast<std::size_t>(i) >= state.size()) continue;
    const int lu = static_cast<int>(static_cast<std::size_t>(i) % width), lv = static_cast<int>(static_cast<std::size_t>(i) / width);
    for (const auto& e : kDirs) {
      const int u = lu + e[0], v = lv + e[1];
      if (u < 0 || v < 0 || u >= in.width || v >= in.height) continue;
      std::uint8_t& st = state[static_cast<std::size_t>(v) * width + static_cast<std::size_t>(u)];
      if (st != 0) continue;  // on the layer, or seen already
      st = 2;
      const double h = below(u, v);
      if (!(h > band_m)) continue;
      double share_sum = 0.0;
      int n = 0;
      for (const auto& d : kDirs) {
        // The layer pixel on one side, the surface beyond on the other.
        if (!on_layer(u - d[0], v - d[1])) continue;
        const double h_beyond = below(u + d[0], v + d[1]);
        if (!(h_beyond >= min_drop_m) || !(h_beyond > h)) continue;
        share_sum += std::clamp(1.0 - h / h_beyond, 0.0, 1.0);
        ++n;
      }
      if (n == 0) continue;
      double fx = 0.0, fy = 0.0;
      if (!geo->cell_of(u, v, &fx, &fy)) continue;
      RimPixel r;
      r.at_m = (geo->origin_m + geo->cell_m * Eigen::Vector2d(fx, fy)).cast<float>();
      r.top_share = static_cast<float>(share_sum / n);
      rim.push_back(r);
    }
  }
  return rim;
}

}  // namespace palletd
