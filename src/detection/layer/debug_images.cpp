// Debug pictures of the layer extraction (see palletd/detection/layer_debug.hpp).
#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/detection/layer_debug.hpp"

namespace palletd {
namespace {

cv::Mat depth_background(const Frame& frame) {
  const int w = frame.intrinsics.width, h = frame.intrinsics.height;
  cv::Mat grey(h, w, CV_8U, cv::Scalar(0));
  if (frame.depth.size() != frame.pixel_count() || w <= 0 || h <= 0) return cv::Mat(std::max(h, 1), std::max(w, 1), CV_8UC3, cv::Scalar(0, 0, 0));
  std::uint16_t lo = 0xFFFF, hi = 0;
  for (const std::uint16_t d : frame.depth) {
    if (d == 0) continue;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  const double span = hi > lo ? static_cast<double>(hi - lo) : 1.0;
  for (int v = 0; v < h; ++v) {
    auto* row = grey.ptr<std::uint8_t>(v);
    for (int u = 0; u < w; ++u) {
      const std::uint16_t d = frame.depth[static_cast<std::size_t>(v * w + u)];
      row[u] = d == 0 ? 0 : static_cast<std::uint8_t>(40.0 + 200.0 * (1.0 - static_cast<double>(d - lo) / span));
    }
  }
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

/// Projects layer-frame points [m] into pixel coordinates.
std::vector<cv::Point2f> project(const Frame& frame, const LayerResult& result, const std::vector<Eigen::Vector2d>& pts) {
  std::vector<cv::Point2f> out;
  if (pts.empty()) return out;
  const Intrinsics& K = frame.intrinsics;
  std::vector<cv::Point3d> cam;
  cam.reserve(pts.size());
  for (const auto& p : pts) {
    const Eigen::Vector3d c = result.T_camera_layer * Eigen::Vector3d(p.x(), p.y(), 0.0);
    cam.emplace_back(c.x(), c.y(), c.z());
  }
  const cv::Mat camera_matrix = (cv::Mat_<double>(3, 3) << K.fx, 0.0, K.cx, 0.0, K.fy, K.cy, 0.0, 0.0, 1.0);
  cv::Mat dist = cv::Mat::zeros(1, 5, CV_64F);
  if (K.distortion)
    for (int i = 0; i < 5; ++i) dist.at<double>(i) = (*K.distortion)[static_cast<std::size_t>(i)];
  std::vector<cv::Point2d> img;
  cv::projectPoints(cam, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix, dist, img);
  for (const auto& p : img) out.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  return out;
}

void draw_ring(cv::Mat& img, const std::vector<cv::Point2f>& pts, const cv::Scalar& colour, bool corners) {
  std::vector<cv::Point> poly;
  for (const auto& p : pts) poly.emplace_back(cvRound(p.x), cvRound(p.y));
  if (poly.size() >= 2) cv::polylines(img, std::vector<std::vector<cv::Point>>{poly}, true, colour, 1, cv::LINE_AA);
  if (corners)
    for (const auto& p : poly) cv::circle(img, p, 3, cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
}

}  // namespace

std::vector<std::pair<std::string, cv::Mat>> render_layer_debug_images(const Frame& frame, const LayerResult& result,
                                                                       const LayerTrace& trace) {
  std::vector<std::pair<std::string, cv::Mat>> out;
  const cv::Mat base = depth_background(frame);
  const bool have_mask = trace.width == base.cols && trace.height == base.rows &&
                         trace.layer_mask.size() == static_cast<std::size_t>(base.cols * base.rows);

  cv::Mat mask_img = base.clone();
  if (have_mask) {
    for (int v = 0; v < base.rows; ++v)
      for (int u = 0; u < base.cols; ++u)
        if (trace.layer_mask[static_cast<std::size_t>(v * base.cols + u)] != 0) {
          auto& px = mask_img.at<cv::Vec3b>(v, u);
          px = cv::Vec3b(static_cast<std::uint8_t>(px[0] / 2), static_cast<std::uint8_t>(128 + px[1] / 2),
                         static_cast<std::uint8_t>(px[2] / 2));
        }
  }
  out.emplace_back("layer_mask", mask_img);

  cv::Mat border_img = base.clone();
  for (const std::int32_t i : trace.border_pixels) {
    const int u = i % std::max(base.cols, 1), v = i / std::max(base.cols, 1);
    if (v < base.rows) border_img.at<cv::Vec3b>(v, u) = cv::Vec3b(0, 0, 255);
  }
  out.emplace_back("border_points", border_img);

  cv::Mat graph_img = base.clone();
  std::vector<Eigen::Vector2d> ends;
  ends.reserve(trace.crust_edges.size() * 2);
  for (const auto& [a, b] : trace.crust_edges) {
    ends.push_back(a);
    ends.push_back(b);
  }
  const std::vector<cv::Point2f> img_ends = project(frame, result, ends);
  for (std::size_t k = 0; k + 1 < img_ends.size(); k += 2)
    cv::line(graph_img, img_ends[k], img_ends[k + 1], cv::Scalar(255, 128, 0), 1, cv::LINE_AA);
  out.emplace_back("crust_graph", graph_img);

  cv::Mat rings_img = base.clone();
  for (const auto& ring : trace.crust_rings) draw_ring(rings_img, project(frame, result, ring), cv::Scalar(255, 0, 255), false);
  for (const auto& poly : result.polygons) {
    draw_ring(rings_img, project(frame, result, poly.outer), cv::Scalar(0, 255, 0), true);
    for (const auto& hole : poly.holes) draw_ring(rings_img, project(frame, result, hole), cv::Scalar(0, 0, 255), true);
  }
  out.emplace_back("rings", rings_img);
  return out;
}

}  // namespace palletd
