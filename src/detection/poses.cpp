#include "poses.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace palletd {

namespace {

// Position used for ordering: base frame when calibrated, else the layer frame (x, y in the plane).
Eigen::Vector2d ordering_position(const DetectedBox& box) {
  if (box.base_position) return box.base_position->head<2>();
  return box.in_layer.center;
}

void assign_pick_order(std::vector<DetectedBox>& boxes, PickOrder order) {
  std::vector<std::size_t> idx(boxes.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  if (!boxes.empty()) {
    // Reference point: the robot base (origin) when calibrated; else the layer's centroid.
    Eigen::Vector2d reference = Eigen::Vector2d::Zero();
    if (!boxes.front().base_position) {
      for (const auto& b : boxes) reference += b.in_layer.center;
      reference /= static_cast<double>(boxes.size());
    }
    // Rows are grouped with a tolerance of half the smallest box side.
    double row_tolerance_m = 1e9;
    for (const auto& b : boxes) row_tolerance_m = std::min(row_tolerance_m, 0.5 * b.short_m);
    auto key_distance = [&](std::size_t i) { return (ordering_position(boxes[i]) - reference).norm(); };
    switch (order) {
      case PickOrder::kFarCornerFirst:
        std::stable_sort(idx.begin(), idx.end(),
                         [&](std::size_t a, std::size_t b) { return key_distance(a) > key_distance(b); });
        break;
      case PickOrder::kNearestFirst:
        std::stable_sort(idx.begin(), idx.end(),
                         [&](std::size_t a, std::size_t b) { return key_distance(a) < key_distance(b); });
        break;
      case PickOrder::kRowMajor:
        std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
          const Eigen::Vector2d pa = ordering_position(boxes[a]);
          const Eigen::Vector2d pb = ordering_position(boxes[b]);
          if (std::abs(pa.x() - pb.x()) > row_tolerance_m) return pa.x() < pb.x();
          return pa.y() < pb.y();
        });
        break;
    }
  }
  std::vector<DetectedBox> sorted;
  sorted.reserve(boxes.size());
  for (std::size_t k = 0; k < idx.size(); ++k) {
    sorted.push_back(boxes[idx[k]]);
    sorted.back().pick_index = static_cast<int>(k);
  }
  boxes = std::move(sorted);
}

}  // namespace

void place_from_layer(DetectedBox& box, const Eigen::Isometry3d& T_camera_layer,
                      const std::optional<Eigen::Isometry3d>& T_base_camera) {
  const Box2d& b = box.in_layer;
  const Eigen::Matrix3d R_camera_layer = T_camera_layer.linear();
  box.center = T_camera_layer * Eigen::Vector3d(b.center.x(), b.center.y(), 0.0);
  box.long_axis = R_camera_layer * Eigen::Vector3d(std::cos(b.yaw_rad), std::sin(b.yaw_rad), 0.0);
  box.normal = R_camera_layer * Eigen::Vector3d::UnitZ();
  if (T_base_camera) {
    box.base_position = *T_base_camera * box.center;
    box.base_yaw_deg = axis_yaw_deg(T_base_camera->linear() * box.long_axis);
  }
}

std::vector<DetectedBox> to_detected_boxes(const std::vector<LayoutBox>& boxes,
                                           const Eigen::Isometry3d& T_camera_layer,
                                           const std::optional<Eigen::Isometry3d>& T_base_camera,
                                           PickOrder order) {
  std::vector<DetectedBox> out;
  out.reserve(boxes.size());
  for (const LayoutBox& b : boxes) {
    DetectedBox d;
    d.in_layer = b;
    d.long_m = b.long_m;
    d.short_m = b.short_m;
    d.format = b.format;
    d.score = b.score;
    d.partly_unseen = b.partly_unseen;
    d.measured_long_m = b.evidence.measured_long_m;
    d.measured_short_m = b.evidence.measured_short_m;
    d.run_long_m = b.evidence.run_long_m;
    d.run_short_m = b.evidence.run_short_m;
    ScoreTerms& t = d.score_terms;
    t.support = b.score;
    t.inside = b.evidence.inside;
    t.edge_seams = b.evidence.edge_seams;
    t.interior_seam = b.evidence.interior_seam;
    t.position_sigma_mm = b.evidence.position_sigma_m < 0 ? -1.0 : 1e3 * b.evidence.position_sigma_m;
    t.refine_shift_mm = 1e3 * b.evidence.refine_shift_m;
    t.partly_unseen = b.partly_unseen;
    t.contested = b.evidence.contested;
    place_from_layer(d, T_camera_layer, T_base_camera);
    out.push_back(std::move(d));
  }
  assign_pick_order(out, order);
  return out;
}

}  // namespace palletd
