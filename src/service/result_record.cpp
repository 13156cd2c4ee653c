#include "result_record.hpp"

#include <algorithm>
#include <cmath>

namespace palletd {

void mark_failed(modbus::ResultRecord& record, modbus::ErrorCode code, std::uint16_t detail) {
  record.status = modbus::ResultStatus::kFailed;
  record.error = code;
  record.error_detail = detail;
  record.boxes.clear();
  record.boxes_found = 0;
}

modbus::DetectionFailure failure_of(DetectionStatus status) {
  switch (status) {
    case DetectionStatus::kNoPlane: return modbus::DetectionFailure::kNoPlane;
    case DetectionStatus::kNoLayer: return modbus::DetectionFailure::kNoLayer;
    case DetectionStatus::kNoLayout: return modbus::DetectionFailure::kNoLayout;
    case DetectionStatus::kBadFrame: return modbus::DetectionFailure::kBadFrame;
    case DetectionStatus::kRecipeMismatch: return modbus::DetectionFailure::kRecipeMismatch;
    case DetectionStatus::kOk:
    case DetectionStatus::kEmpty:
    case DetectionStatus::kSlipSheet: break;
  }
  return modbus::DetectionFailure::kUnknown;
}

modbus::PickStatus pick_status_of(const BoxPick& pick) {
  if (pick.pickable) return modbus::PickStatus::kPickable;
  switch (pick.blocked_by) {
    case PickBlock::kRoi: return modbus::PickStatus::kRoi;
    case PickBlock::kHigherLevel: return modbus::PickStatus::kHigherLevel;
    case PickBlock::kYawLimits: return modbus::PickStatus::kYawLimits;
    case PickBlock::kNeighbour:
    case PickBlock::kNone: break;  // not pickable now for no lasting reason: what stands around it
  }
  return modbus::PickStatus::kNeighbour;
}

namespace {

// Layer "height": base z of the layer under the boxes when calibrated; else the depth at which
// the optical axis meets the layer plane [m].
double layer_z_m(const Detection& detection, bool base_frame) {
  if (base_frame && !detection.boxes.empty()) {
    double z = 0.0;
    for (const auto& b : detection.boxes) z += b.base_position->z();
    return z / static_cast<double>(detection.boxes.size());
  }
  const Plane& p = detection.plane_camera;
  if (std::abs(p.normal.z()) < 1e-9) return 0.0;
  return -p.d / p.normal.z();
}

std::uint16_t saturate_u16(std::size_t n) { return static_cast<std::uint16_t>(std::min<std::size_t>(n, 65535)); }

// The pick fields of `r` (its boxes filled already) from the boxes' `pick` and the detection's
// groups. Both hold the boxes in pick order, so a group's first box index is its first box slot.
void fill_picks(const Detection& detection, modbus::ResultRecord& r) {
  r.picking = std::any_of(detection.boxes.begin(), detection.boxes.end(),
                          [](const DetectedBox& b) { return b.pick.has_value(); });
  if (!r.picking) return;
  r.pickable_boxes = saturate_u16(static_cast<std::size_t>(
      std::count_if(detection.boxes.begin(), detection.boxes.end(),
                    [](const DetectedBox& b) { return b.pick && b.pick->pickable; })));
  for (std::size_t i = 0; i < r.boxes.size(); ++i)
    if (detection.boxes[i].pick) r.boxes[i].pick_status = pick_status_of(*detection.boxes[i].pick);
  r.groups_found = saturate_u16(detection.groups.size());
  for (const PickGroup& g : detection.groups) {
    if (g.boxes.empty()) continue;
    modbus::GroupRecord out;
    out.x_m = g.tcp.position_m.x();
    out.y_m = g.tcp.position_m.y();
    out.z_m = g.tcp.position_m.z();
    out.yaw_deg = g.tcp.yaw_deg;
    out.box_count = saturate_u16(g.boxes.size());
    out.first_box = static_cast<std::uint16_t>(std::clamp(g.boxes.front(), 0, 65535));
    out.pick_index = static_cast<std::uint16_t>(std::clamp(g.pick_index + 1, 0, 65535));
    r.groups.push_back(out);
  }
}

}  // namespace

modbus::ResultRecord to_result_record(const Detection& detection, bool base_frame) {
  modbus::ResultRecord r;
  if (detection.status == DetectionStatus::kEmpty || detection.status == DetectionStatus::kSlipSheet) {
    r.status = modbus::ResultStatus::kNoBoxes;
    r.detail = detection.status == DetectionStatus::kEmpty ? modbus::ResultDetail::kEmpty
                                                           : modbus::ResultDetail::kSlipSheet;
  } else if (is_failure(detection.status)) {
    r.status = modbus::ResultStatus::kFailed;
    r.error = modbus::ErrorCode::kDetectionFailed;
    r.error_detail = static_cast<std::uint16_t>(failure_of(detection.status));
  } else {
    r.status = detection.boxes.empty() ? modbus::ResultStatus::kNoBoxes : modbus::ResultStatus::kOk;
  }
  r.height_above_pallet_m = detection.height_above_pallet_m;
  r.layers_remaining = detection.layers_remaining;
  r.height_off_layers = detection.height_off_layers;
  r.boxes_found = static_cast<std::uint16_t>(std::min<std::size_t>(detection.boxes.size(), 65535));
  const std::size_t n = std::min<std::size_t>(detection.boxes.size(), modbus::kMaxBoxes);
  // Boxes go out in pick order (detect() sorted them; pick_index 0 first).
  for (std::size_t i = 0; i < n; ++i) {
    const DetectedBox& b = detection.boxes[i];
    modbus::BoxRecord out;
    const bool in_base = base_frame && b.base_position.has_value();
    const Eigen::Vector3d p = in_base ? *b.base_position : b.center;
    out.x_m = p.x();
    out.y_m = p.y();
    out.z_m = p.z();
    out.yaw_deg = in_base && b.base_yaw_deg ? *b.base_yaw_deg : axis_yaw_deg(b.long_axis);
    out.format = b.format < 0 ? std::uint16_t{0xFFFF} : static_cast<std::uint16_t>(b.format);
    out.long_m = b.long_m;
    out.short_m = b.short_m;
    out.score = b.score;
    out.pick_index = static_cast<std::uint16_t>(b.pick_index + 1);
    r.boxes.push_back(out);
  }
  r.ambiguous = detection.ambiguous;
  r.budget_exhausted = detection.budget_exhausted;
  r.layer_clipped = detection.clipped_by_image_border;
  r.outline_unobserved = detection.outline_unobserved;
  r.layer_z_m = detection.status == DetectionStatus::kOk ? layer_z_m(detection, base_frame) : 0.0;
  r.coverage = detection.coverage;
  r.layout_confidence = detection.layout_confidence;
  r.formats_measured = detection.formats_measured;
  if (detection.recipe_check.best_recipe)
    r.best_recipe = static_cast<std::uint16_t>(std::clamp(*detection.recipe_check.best_recipe, 0, 65535));
  fill_picks(detection, r);
  auto total = detection.timing_ms.find("total");
  r.processing_ms = total != detection.timing_ms.end() ? total->second : 0.0;
  return r;
}

}  // namespace palletd
