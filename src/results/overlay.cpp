#include "palletd/results/overlay.hpp"
#include "palletd/results/overlay_draw.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace palletd {

double overlay_scale(const Intrinsics& intrinsics) {
  return intrinsics.width < 500 ? std::ceil(640.0 / intrinsics.width) : 1.0;
}

// Depth in a colour map, stretched over the frame's valid depth range; invalid pixels black.
cv::Mat colour_depth_image(const Frame& frame) {
  const int w = frame.intrinsics.width, h = frame.intrinsics.height;
  std::uint16_t lo = std::numeric_limits<std::uint16_t>::max(), hi = 0;
  for (std::uint16_t d : frame.depth) {
    if (d == 0) continue;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  cv::Mat grey(h, w, CV_8UC1, cv::Scalar(0));
  const double span = hi > lo ? static_cast<double>(hi - lo) : 1.0;
  for (int v = 0; v < h; ++v) {
    auto* row = grey.ptr<std::uint8_t>(v);
    for (int u = 0; u < w; ++u) {
      const std::uint16_t d = frame.depth[static_cast<std::size_t>(v * w + u)];
      // Near is bright: 255 at the nearest depth, 1 at the furthest (0 stays "no data").
      row[u] = d == 0 ? 0 : static_cast<std::uint8_t>(1.0 + 254.0 * (static_cast<double>(hi - d) / span));
    }
  }
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar(0, 0, 0), grey == 0);
  return colour;
}

cv::Point2d project_to_overlay(const Intrinsics& in, const Eigen::Vector3d& p_camera, double scale) {
  const double u = in.fx * p_camera.x() / p_camera.z() + in.cx;
  const double v = in.fy * p_camera.y() / p_camera.z() + in.cy;
  return {(u + 0.5) * scale - 0.5, (v + 0.5) * scale - 0.5};
}

namespace {

std::vector<cv::Point> project_ring(const Intrinsics& in, const Eigen::Isometry3d& T_camera_layer,
                                    const Ring2d& ring, double scale) {
  std::vector<cv::Point> out;
  out.reserve(ring.size());
  for (const auto& p : ring) {
    const cv::Point2d q =
        project_to_overlay(in, T_camera_layer * Eigen::Vector3d(p.x(), p.y(), 0.0), scale);
    out.emplace_back(static_cast<int>(std::lround(q.x)), static_cast<int>(std::lround(q.y)));
  }
  return out;
}

std::vector<cv::Point> box_quad(const Intrinsics& in, const Eigen::Isometry3d& T_camera_layer,
                                const DetectedBox& box, double scale) {
  std::vector<cv::Point> quad;
  for (const auto& c : box.in_layer.corners()) {
    const cv::Point2d q = project_to_overlay(in, T_camera_layer * Eigen::Vector3d(c.x(), c.y(), 0.0), scale);
    quad.emplace_back(static_cast<int>(std::lround(q.x)), static_cast<int>(std::lround(q.y)));
  }
  return quad;
}

void draw_text(cv::Mat& image, const std::string& text, cv::Point org, double font, const cv::Scalar& colour) {
  cv::putText(image, text, org, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), 4, cv::LINE_AA);
  cv::putText(image, text, org, cv::FONT_HERSHEY_SIMPLEX, font, colour, 2, cv::LINE_AA);
}

/// The pick check over the result: what the pick took, what it missed or took too, what moved.
void draw_check(cv::Mat& image, const Intrinsics& in, const Eigen::Isometry3d& T_camera_layer,
                const PickCheck& check, double scale) {
  const double font = 0.5 * std::max(1.0, scale * in.width / 640.0);
  for (const BoxCheck& c : check.boxes) {
    const std::vector<cv::Point> quad = box_quad(in, T_camera_layer, c.now, scale);
    const cv::Point2d centre = project_to_overlay(in, c.now.center, scale);
    const cv::Point at(static_cast<int>(centre.x) - 20, static_cast<int>(centre.y) + 22);
    if (!c.present) {  // gone: crossed out, grey when picked, red when it was not
      const cv::Scalar colour = c.picked ? cv::Scalar(160, 160, 160) : cv::Scalar(0, 0, 255);
      cv::polylines(image, std::vector<std::vector<cv::Point>>{quad}, true, colour, 1, cv::LINE_AA);
      cv::line(image, quad[0], quad[2], colour, 1, cv::LINE_AA);
      cv::line(image, quad[1], quad[3], colour, 1, cv::LINE_AA);
      if (!c.picked) draw_text(image, "gone", at, font, colour);
    } else if (c.picked) {
      cv::polylines(image, std::vector<std::vector<cv::Point>>{quad}, true, cv::Scalar(0, 0, 255), 4, cv::LINE_AA);
      draw_text(image, "missed", at, font, cv::Scalar(0, 0, 255));
    } else if (c.moved) {
      cv::polylines(image, std::vector<std::vector<cv::Point>>{quad}, true, cv::Scalar(255, 255, 0), 2, cv::LINE_AA);
      draw_text(image, "moved " + std::to_string(static_cast<int>(std::lround(c.shift_mm))) + " mm", at, font,
                cv::Scalar(255, 255, 0));
    }
  }
}

}  // namespace

/// Box outline colour (BGR): magenta without a gripper; with one, green when the robot can take
/// the box now, orange when a neighbour has to go first, red when something else blocks it.
cv::Scalar box_colour(const DetectedBox& box) {
  if (!box.pick) return {255, 0, 255};
  if (box.pick->pickable) return {0, 200, 0};
  if (box.pick->blocked_by == PickBlock::kNeighbour) return {0, 165, 255};
  return {0, 0, 255};
}

void draw_region_edges(cv::Mat& image, const Frame& frame, const RegionOfInterest& roi, double scale) {
  const bool in_base = roi.frame == RegionOfInterest::Frame::kBase;
  if (in_base && !frame.T_base_camera) return;
  const Eigen::Isometry3d T_camera_roi = in_base ? frame.T_base_camera->inverse() : Eigen::Isometry3d::Identity();
  auto corner = [&](int i) {
    return T_camera_roi * Eigen::Vector3d((i & 1) != 0 ? roi.max_m.x() : roi.min_m.x(),
                                          (i & 2) != 0 ? roi.max_m.y() : roi.min_m.y(),
                                          (i & 4) != 0 ? roi.max_m.z() : roi.min_m.z());
  };
  constexpr double kMinDepth_m = 0.05;  // edges reaching behind the camera are left out
  for (int a = 0; a < 8; ++a) {
    for (int bit : {1, 2, 4}) {
      if ((a & bit) != 0) continue;
      const Eigen::Vector3d p = corner(a), q = corner(a | bit);
      if (p.z() < kMinDepth_m || q.z() < kMinDepth_m) continue;
      const cv::Point2d u = project_to_overlay(frame.intrinsics, p, scale);
      const cv::Point2d v = project_to_overlay(frame.intrinsics, q, scale);
      cv::line(image, cv::Point(static_cast<int>(std::lround(u.x)), static_cast<int>(std::lround(u.y))),
               cv::Point(static_cast<int>(std::lround(v.x)), static_cast<int>(std::lround(v.y))),
               cv::Scalar(0, 215, 255), 1, cv::LINE_AA);
    }
  }
}

std::vector<std::uint8_t> render_overlay_png(const Frame& frame, const Detection& detection,
                                             const PickCheck* check) {
  const Intrinsics& in = frame.intrinsics;
  if (!in.valid() || frame.depth.size() != frame.pixel_count()) return {};
  const double scale = overlay_scale(in);
  cv::Mat image = colour_depth_image(frame);
  if (scale > 1.0) cv::resize(image, image, cv::Size(), scale, scale, cv::INTER_NEAREST);

  if (detection.roi) draw_region_edges(image, frame, *detection.roi, scale);
  const LayerResult& layer = detection.layer;
  const int thick = 2;
  for (const auto& polygon : layer.polygons) {
    std::vector<std::vector<cv::Point>> rings{project_ring(in, layer.T_camera_layer, polygon.outer, scale)};
    for (const auto& hole : polygon.holes) rings.push_back(project_ring(in, layer.T_camera_layer, hole, scale));
    cv::polylines(image, rings, true, cv::Scalar(255, 255, 255), thick, cv::LINE_AA);
  }
  for (const auto& box : detection.boxes) {
    const std::vector<cv::Point> quad = box_quad(in, layer.T_camera_layer, box, scale);
    cv::polylines(image, std::vector<std::vector<cv::Point>>{quad}, true, cv::Scalar(0, 0, 0), thick + 2,
                  cv::LINE_AA);
    cv::polylines(image, std::vector<std::vector<cv::Point>>{quad}, true, box_colour(box), thick, cv::LINE_AA);
    const cv::Point2d c = project_to_overlay(in, box.center, scale);
    const std::string label = std::to_string(box.pick_index + 1);
    int baseline = 0;
    const double font = 0.6 * std::max(1.0, scale * in.width / 640.0);
    const cv::Size size = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, 2, &baseline);
    const cv::Point org(static_cast<int>(c.x) - size.width / 2, static_cast<int>(c.y) + size.height / 2);
    cv::putText(image, label, org, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(0, 0, 0), 4, cv::LINE_AA);
    cv::putText(image, label, org, cv::FONT_HERSHEY_SIMPLEX, font, cv::Scalar(255, 255, 255), 2, cv::LINE_AA);
  }
  if (check != nullptr) draw_check(image, in, layer.T_camera_layer, *check, scale);
  std::string caption = std::string(to_string(detection.status)) + "  boxes: " +
                        std::to_string(detection.boxes.size());
  if (detection.ambiguous) caption += "  AMBIGUOUS";
  if (check != nullptr) caption += std::string("  check: ") + to_string(check->verdict);
  if (std::any_of(detection.boxes.begin(), detection.boxes.end(), [](const DetectedBox& b) { return b.pick.has_value(); }))
    caption += "  pickable: " + std::to_string(std::count_if(detection.boxes.begin(), detection.boxes.end(),
                                                              [](const DetectedBox& b) { return b.pick->pickable; }));
  if (detection.status != DetectionStatus::kOk && !detection.message.empty()) caption += "  " + detection.message;
  cv::putText(image, caption, cv::Point(8, 22), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(0, 0, 0), 4, cv::LINE_AA);
  cv::putText(image, caption, cv::Point(8, 22), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
  std::vector<std::uint8_t> png;
  cv::imencode(".png", image, png);
  return png;
}

}  // namespace palletd
