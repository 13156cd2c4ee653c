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

/// Pose noise moves a box's centre by a few millimetres: keys closer than this are one tie.
constexpr double kOrderTie_m = 0.01;

/// Each key's class: keys sorted ascending, a class holds the keys within `tolerance` of its
/// first (smallest) one. Keys a few millimetres apart (boxes placed symmetrically about the
/// reference, a row) land in one class whichever way noise orders them; the next key decides.
std::vector<int> tie_classes(const std::vector<double>& keys, double tolerance) {
  std::vector<std::size_t> idx(keys.size());
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
  std::vector<int> out(keys.size(), 0);
  int current = -1;
  double first = 0.0;
  for (const std::size_t i : idx) {
    if (current < 0 || keys[i] - first > tolerance) {
      ++current;
      first = keys[i];
    }
    out[i] = current;
  }
  return out;
}

}  // namespace

void sort_by_pick_order(std::vector<DetectedBox>& boxes, PickOrder order) {
  const std::size_t n = boxes.size();
  if (n == 0) return;
  // Reference point: the robot base (origin) when calibrated; else the layer's centroid.
  Eigen::Vector2d reference = Eigen::Vector2d::Zero();
  if (!boxes.front().base_position) {
    for (const auto& b : boxes) reference += b.in_layer.center;
    reference /= static_cast<double>(n);
  }
  std::vector<double> distance(n), x(n), y(n);
  double row_tolerance_m = 1e9;  // rows: half the smallest box side
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p = ordering_position(boxes[i]);
    distance[i] = (p - reference).norm();
    x[i] = p.x();
    y[i] = p.y();
    row_tolerance_m = std::min(row_tolerance_m, 0.5 * boxes[i].short_m);
  }
  // The order's own key first, then x (not within a row: a row goes by y), then y; keys compared
  // as classes of ties, which keeps the comparison a strict weak order.
  std::vector<int> primary, secondary(n, 0);
  switch (order) {
    case PickOrder::kFarCornerFirst:
      primary = tie_classes(distance, kOrderTie_m);
      for (int& c : primary) c = -c;
      break;
    case PickOrder::kNearestFirst:
      primary = tie_classes(distance, kOrderTie_m);
      break;
    case PickOrder::kRowMajor:
      primary = tie_classes(x, row_tolerance_m);
      break;
  }
  if (order != PickOrder::kRowMajor) secondary = tie_classes(x, kOrderTie_m);
  std::vector<std::size_t> idx(n);
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  std::stable_sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
    if (primary[a] != primary[b]) return primary[a] < primary[b];
    if (secondary[a] != secondary[b]) return secondary[a] < secondary[b];
    return y[a] < y[b];
  });
  std::vector<DetectedBox> sorted;
  sorted.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    sorted.push_back(std::move(boxes[idx[k]]));
    sorted.back().pick_index = static_cast<int>(k);
  }
  boxes = std::move(sorted);
}

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
    d.tape_across = b.evidence.tape_across;
    d.tape_halves = b.evidence.tape_halves;
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
  sort_by_pick_order(out, order);
  return out;
}

}  // namespace palletd
