// The overlay PNG: the region of interest's edges drawn where the region projects.
#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "palletd/frames/frame_io.hpp"
#include "palletd/results/overlay.hpp"

using namespace palletd;

namespace {

/// Distance from pixel q to the segment a-b [px].
double segment_distance(const Eigen::Vector2d& q, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double t = std::clamp((q - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
  return (a + t * ab - q).norm();
}

/// A detection whose layer lies 1.5 m in front of the camera, facing it (no boxes yet).
Detection facing_layer() {
  Detection detection;
  detection.status = DetectionStatus::kOk;
  detection.layer.T_camera_layer = Eigen::Isometry3d::Identity();
  detection.layer.T_camera_layer.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  detection.layer.T_camera_layer.translation() = Eigen::Vector3d(0.0, 0.0, 1.5);
  return detection;
}

/// Box i of three 0.3 x 0.2 m boxes side by side on that layer.
DetectedBox box_in_row(const Detection& detection, int i) {
  DetectedBox b;
  b.in_layer.center = Eigen::Vector2d(-0.35 + 0.35 * i, 0.0);
  b.in_layer.long_m = 0.3;
  b.in_layer.short_m = 0.2;
  b.center = detection.layer.T_camera_layer * Eigen::Vector3d(b.in_layer.center.x(), 0.0, 0.0);
  b.pick_index = i;
  return b;
}

/// The brightest pixel within 2 px of where layer x `x_m` projects on the middle row (a 2 px
/// line may sit a pixel off the projection).
cv::Vec3b colour_near(const cv::Mat& image, const Intrinsics& k, double x_m) {
  const int u = static_cast<int>(std::lround(k.fx * x_m / 1.5 + k.cx));
  const int v = static_cast<int>(std::lround(k.cy));
  cv::Vec3b best(0, 0, 0);
  for (int du = -2; du <= 2; ++du) {
    const cv::Vec3b c = image.at<cv::Vec3b>(v, u + du);
    if (c[0] + c[1] + c[2] > best[0] + best[1] + best[2]) best = c;
  }
  return best;
}

}  // namespace

TEST_CASE("overlay: the region of interest's edges are drawn where the region projects") {
  auto frame = read_frame(std::string(PALLETD_TEST_DATA_DIR) + "/22_block_600x400_xtion");
  REQUIRE(frame);
  REQUIRE(frame->T_base_camera.has_value());
  Detection detection;  // nothing detected: only the region is drawn besides the depth
  const cv::Mat plain = cv::imdecode(render_overlay_png(*frame, detection), cv::IMREAD_COLOR);
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kBase;
  roi.min_m = Eigen::Vector3d(-0.7, -0.5, 0.0);
  roi.max_m = Eigen::Vector3d(0.7, 0.5, 1.5);
  detection.roi = roi;
  const cv::Mat drawn = cv::imdecode(render_overlay_png(*frame, detection), cv::IMREAD_COLOR);
  REQUIRE(plain.size() == drawn.size());
  REQUIRE(drawn.cols == frame->intrinsics.width);  // 640 x 480: not scaled

  // The region's edges in the image (pinhole projection of the corners).
  const Eigen::Isometry3d T_camera_base = frame->T_base_camera->inverse();
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> edges;
  auto pixel = [&](int i) {
    const Eigen::Vector3d p = T_camera_base * Eigen::Vector3d((i & 1) != 0 ? roi.max_m.x() : roi.min_m.x(),
                                                              (i & 2) != 0 ? roi.max_m.y() : roi.min_m.y(),
                                                              (i & 4) != 0 ? roi.max_m.z() : roi.min_m.z());
    const Intrinsics& k = frame->intrinsics;
    return Eigen::Vector2d(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy);
  };
  for (int a = 0; a < 8; ++a)
    for (int bit : {1, 2, 4})
      if ((a & bit) == 0) edges.emplace_back(pixel(a), pixel(a | bit));

  int changed = 0, near_edge = 0;
  for (int v = 40; v < drawn.rows; ++v) {  // below the caption
    for (int u = 0; u < drawn.cols; ++u) {
      if (drawn.at<cv::Vec3b>(v, u) == plain.at<cv::Vec3b>(v, u)) continue;
      ++changed;
      double best = 1e9;
      for (const auto& [a, b] : edges) best = std::min(best, segment_distance(Eigen::Vector2d(u, v), a, b));
      if (best <= 2.5) ++near_edge;
    }
  }
  CHECK(changed > 300);
  CHECK(near_edge == changed);
}

TEST_CASE(
    "overlay: with a gripper, pickable boxes green, boxes waiting for a neighbour orange, blocked red") {
  auto frame = read_frame(std::string(PALLETD_TEST_DATA_DIR) + "/22_block_600x400_xtion");
  REQUIRE(frame);
  Detection detection = facing_layer();
  const PickBlock blocks[3] = {PickBlock::kNone, PickBlock::kNeighbour, PickBlock::kHigherLevel};
  for (int i = 0; i < 3; ++i) {
    DetectedBox& b = detection.boxes.emplace_back(box_in_row(detection, i));
    b.pick = BoxPick{i == 0, blocks[i], TcpPose{}};
  }
  const cv::Mat image = cv::imdecode(render_overlay_png(*frame, detection), cv::IMREAD_COLOR);
  REQUIRE_FALSE(image.empty());
  // Each box's left edge, in the middle of its height: the outline's colour (BGR).
  auto colour_at_left_edge = [&](int i) {
    return colour_near(image, frame->intrinsics, -0.35 + 0.35 * i - 0.15);
  };
  const cv::Vec3b pickable = colour_at_left_edge(0), waiting = colour_at_left_edge(1),
                  blocked = colour_at_left_edge(2);
  CAPTURE(pickable, waiting, blocked);
  CHECK(pickable[1] > 150);  // green
  CHECK(pickable[2] < 80);
  CHECK(waiting[2] > 200);  // orange: red and some green, no blue
  CHECK(waiting[1] > 100);
  CHECK(waiting[0] < 80);
  CHECK(blocked[2] > 200);  // red
  CHECK(blocked[1] < 80);
}

TEST_CASE("overlay: a pick check draws the picked box grey, a box gone too red, a moved box cyan") {
  auto frame = read_frame(std::string(PALLETD_TEST_DATA_DIR) + "/22_block_600x400_xtion");
  REQUIRE(frame);
  Detection detection = facing_layer();
  PickCheck check;
  check.verdict = PickVerdict::kExtraBoxGone;
  for (int i = 0; i < 3; ++i) {
    BoxCheck& c = check.boxes.emplace_back();
    c.box = i;
    c.now = box_in_row(detection, i);
    c.picked = i == 1;
    c.present = i == 0;
    c.moved = i == 0;
    c.shift_mm = 21.0;
  }
  detection.boxes.push_back(check.boxes[0].now);  // the one left, at its new pose
  const cv::Mat image = cv::imdecode(render_overlay_png(*frame, detection, &check), cv::IMREAD_COLOR);
  REQUIRE_FALSE(image.empty());
  const Intrinsics& k = frame->intrinsics;
  auto pixel = [&](double x_m) { return colour_near(image, k, x_m); };
  const cv::Vec3b moved = pixel(-0.35 - 0.15), taken = pixel(0.0), extra = pixel(0.35);
  CAPTURE(moved, taken, extra);
  CHECK(moved[0] > 200);  // cyan outline
  CHECK(moved[1] > 200);
  CHECK(moved[2] < 80);
  CHECK(std::abs(taken[0] - taken[2]) < 20);  // grey cross where the picked box stood
  CHECK(taken[0] > 120);
  CHECK(extra[2] > 200);  // red cross: gone though not picked
  CHECK(extra[0] < 80);
  CHECK(extra[1] < 80);
  // Without the check the same result draws none of that.
  const cv::Mat plain = cv::imdecode(render_overlay_png(*frame, detection), cv::IMREAD_COLOR);
  const cv::Vec3b extra_plain = plain.at<cv::Vec3b>(static_cast<int>(std::lround(k.cy)),
                                                    static_cast<int>(std::lround(k.fx * 0.35 / 1.5 + k.cx)));
  CHECK_FALSE((extra_plain[2] > 200 && extra_plain[0] < 80 && extra_plain[1] < 80));
}
