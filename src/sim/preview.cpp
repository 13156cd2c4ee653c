// palletd sim: a preview image of a simulated frame (depth colour map + truth outlines).
#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/sim/sim.hpp"

namespace palletd::sim {

PreviewImage render_preview(const SimulatedFrame& sim) {
  const Frame& f = sim.frame;
  const int w = f.intrinsics.width, h = f.intrinsics.height;
  double zmin = 1e30, zmax = -1e30;
  for (std::uint16_t raw : f.depth)
    if (raw != 0) {
      zmin = std::min(zmin, raw * f.depth_scale_m);
      zmax = std::max(zmax, raw * f.depth_scale_m);
    }
  cv::Mat gray(h, w, CV_8U, cv::Scalar(0)), valid(h, w, CV_8U, cv::Scalar(0));
  const double span = std::max(zmax - zmin, 1e-3);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const std::uint16_t raw = f.depth[static_cast<std::size_t>(v * w + u)];
      if (raw == 0) continue;
      gray.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(std::lround(255.0 * (raw * f.depth_scale_m - zmin) / span));
      valid.at<std::uint8_t>(v, u) = 255;
    }
  cv::Mat colour, out(h, w, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::applyColorMap(gray, colour, cv::COLORMAP_TURBO);
  colour.copyTo(out, valid);
  // Upscale small images so the outlines stay readable.
  const int scale = w < 400 ? 2 : 1;
  if (scale > 1) cv::resize(out, out, cv::Size(w * scale, h * scale), 0, 0, cv::INTER_NEAREST);
  for (const TruthBox& box : sim.truth.boxes) {
    std::vector<cv::Point> poly;
    for (const Eigen::Vector3d& c : truth_corners(box)) {
      Eigen::Vector2d px;
      if (!project(f.intrinsics, c, px)) continue;
      poly.emplace_back(static_cast<int>(std::lround((px.x() + 0.5) * scale - 0.5)),
                        static_cast<int>(std::lround((px.y() + 0.5) * scale - 0.5)));
    }
    if (poly.size() == 4) cv::polylines(out, poly, true, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    Eigen::Vector2d centre;
    if (project(f.intrinsics, box.center, centre))
      cv::circle(out, cv::Point(static_cast<int>(std::lround(centre.x() * scale)), static_cast<int>(std::lround(centre.y() * scale))),
                 2, cv::Scalar(255, 255, 255), cv::FILLED);
  }
  PreviewImage image;
  image.width = out.cols;
  image.height = out.rows;
  image.bgr.assign(out.data, out.data + out.total() * 3);
  return image;
}

}  // namespace palletd::sim
