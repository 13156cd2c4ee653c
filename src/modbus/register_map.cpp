#include "palletd/modbus/register_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace palletd::modbus {
namespace {

template <typename Int>
Int saturate_round(double value) {
  if (!std::isfinite(value)) return 0;
  const double r = std::round(value);
  constexpr double kLowest = static_cast<double>(std::numeric_limits<Int>::min());
  constexpr double kHighest = static_cast<double>(std::numeric_limits<Int>::max());
  return static_cast<Int>(std::clamp(r, kLowest, kHighest));
}

std::uint16_t low16(std::uint32_t v) { return static_cast<std::uint16_t>(v & 0xFFFFu); }
std::uint16_t high16(std::uint32_t v) { return static_cast<std::uint16_t>(v >> 16); }

}  // namespace

std::int32_t metres_to_tenth_mm(double metres) { return saturate_round<std::int32_t>(metres * 1e4); }
double tenth_mm_to_metres(std::int32_t value) { return static_cast<double>(value) * 1e-4; }

std::int16_t degrees_to_hundredths(double degrees) {
  if (!std::isfinite(degrees)) return 0;
  double wrapped = std::fmod(degrees, 360.0);
  if (wrapped > 180.0) wrapped -= 360.0;
  if (wrapped < -180.0) wrapped += 360.0;
  return static_cast<std::int16_t>(std::clamp(std::round(wrapped * 100.0), -18000.0, 18000.0));
}
double hundredths_to_degrees(std::int16_t value) { return static_cast<double>(value) * 0.01; }

std::uint16_t unit_to_permille(double value) {
  if (!std::isfinite(value)) return 0;
  return static_cast<std::uint16_t>(std::clamp(std::round(value * 1000.0), 0.0, 1000.0));
}

std::uint16_t milliseconds_to_register(double ms) { return saturate_round<std::uint16_t>(ms); }

void put_u32(std::uint16_t* dst, std::uint32_t value, WordOrder order) {
  if (order == WordOrder::kHighWordFirst) {
    dst[0] = high16(value);
    dst[1] = low16(value);
  } else {
    dst[0] = low16(value);
    dst[1] = high16(value);
  }
}

std::uint32_t get_u32(const std::uint16_t* src, WordOrder order) {
  const std::uint32_t first = src[0];
  const std::uint32_t second = src[1];
  return order == WordOrder::kHighWordFirst ? (first << 16) | second : (second << 16) | first;
}

void put_i32(std::uint16_t* dst, std::int32_t value, WordOrder order) {
  put_u32(dst, static_cast<std::uint32_t>(value), order);
}

std::int32_t get_i32(const std::uint16_t* src, WordOrder order) {
  // two's complement reinterpretation without implementation-defined conversion
  const std::uint32_t u = get_u32(src, order);
  return u <= 0x7FFFFFFFu ? static_cast<std::int32_t>(u)
                          : -static_cast<std::int32_t>(~u) - 1;
}

void encode_status(const StatusRecord& s, WordOrder order, RegisterImage& image) {
  std::uint16_t* r = image.data();
  r[kRegStatusWord] = s.status_word;
  r[kRegErrorCode] = static_cast<std::uint16_t>(s.error);
  r[kRegErrorDetail] = s.error_detail;
  r[kRegHeartbeat] = s.heartbeat;
  r[kRegActiveRecipe] = s.active_recipe;
  r[kRegAcquisitionId] = s.acquisition_id;
  r[kRegStatusResultId] = s.result_id;
  r[kRegLastRequestId] = s.last_request_id;
  r[kRegInterfaceVersion] = kInterfaceVersion;
  std::uint16_t format = 0;
  if (order == WordOrder::kLowWordFirst) format |= kFmtLowWordFirst;
  if (s.poses_in_camera_frame) format |= kFmtCameraFrame;
  r[kRegFormatFlags] = format;
  put_u32(r + kRegTestPattern, kTestPattern, order);
  r[kRegMissedTriggers] = s.missed_triggers;
  r[kRegProcessingMs] = milliseconds_to_register(s.processing_ms);
  r[kRegLatencyMs] = milliseconds_to_register(s.latency_ms);
  put_u32(r + kRegFramesGrabbed, s.frames_grabbed, order);
  r[kRegCameraReconnects] = s.camera_reconnects;
  const CameraFaultCounters& f = s.camera_faults;
  put_u32(r + kRegIncompleteFrames, f.incomplete_frames, order);
  put_u32(r + kRegGrabTimeouts, f.grab_timeouts, order);
  put_u32(r + kRegDroppedFrames, f.dropped_frames, order);
  put_u32(r + kRegCameraLosses, f.camera_losses, order);
  put_u32(r + kRegCameraRestarts, f.camera_restarts, order);
  put_u32(r + kRegResentPackets, f.resent_packets, order);
  const ConnectionCounters& c = s.connections;
  put_u32(r + kRegConnectionsEvicted, c.evicted, order);
  put_u32(r + kRegConnectionsRefused, c.refused, order);
  r[kRegOpenConnections] = c.open;
  r[kRegMaxConnections] = c.max_connections;
  const HealthRecord& h = s.health;
  r[kRegHealthFlags] = h.flags;
  r[kRegHealthFrames] = h.frames;
  r[kRegInvalidPermille] = unit_to_permille(h.invalid_fraction);
  r[kRegFlyingPermille] = unit_to_permille(h.flying_fraction);
  r[kRegSaturatedPermille] = unit_to_permille(h.saturated_fraction);
  r[kRegNoiseRatio] = saturate_round<std::uint16_t>(h.noise_ratio * 100.0);
  r[kRegDriftShift] = saturate_round<std::uint16_t>(h.drift_shift_mm * 10.0);
  r[kRegDriftAngle] = saturate_round<std::uint16_t>(h.drift_angle_deg * 100.0);
}

void clear_result(RegisterImage& image) {
  std::fill(image.begin() + kResultStart, image.end(), std::uint16_t{0});
  std::fill_n(image.begin() + kResultExtStart, kResultExtCount, std::uint16_t{0});
}

namespace {

/// A side length in 0.1 mm, saturated to 0..65535.
std::uint16_t tenth_mm_u16(double m) {
  return static_cast<std::uint16_t>(std::clamp<std::int32_t>(metres_to_tenth_mm(m), 0, 65535));
}

std::int16_t as_i16(std::uint16_t v) {
  return v <= 0x7FFF ? static_cast<std::int16_t>(v) : static_cast<std::int16_t>(-static_cast<int>(0xFFFF - v) - 1);
}

/// x, y, z (int32, 0.1 mm) and yaw (int16, 0.01 deg) of a box or group slot.
template <typename Pose>
void encode_pose(const Pose& pose, WordOrder order, std::uint16_t* slot) {
  put_i32(slot + 0, metres_to_tenth_mm(pose.x_m), order);
  put_i32(slot + 2, metres_to_tenth_mm(pose.y_m), order);
  put_i32(slot + 4, metres_to_tenth_mm(pose.z_m), order);
  slot[6] = static_cast<std::uint16_t>(degrees_to_hundredths(pose.yaw_deg));
}

template <typename Pose>
void decode_pose(const std::uint16_t* slot, WordOrder order, Pose& pose) {
  pose.x_m = tenth_mm_to_metres(get_i32(slot + 0, order));
  pose.y_m = tenth_mm_to_metres(get_i32(slot + 2, order));
  pose.z_m = tenth_mm_to_metres(get_i32(slot + 4, order));
  pose.yaw_deg = hundredths_to_degrees(as_i16(slot[6]));
}

/// A group is reported when all its boxes lie in the reported box slots: the PLC then finds each
/// of them in 210 + 10 i.
bool group_in_slots(const GroupRecord& group, std::uint16_t reported_boxes) {
  return group.box_count > 0 && group.first_box + group.box_count <= reported_boxes;
}

/// Registers 540..902 of a result that carries pick data (encode_result() cleared them).
void encode_picks(const ResultRecord& result, std::uint16_t reported_boxes, WordOrder order,
                  std::uint16_t* r) {
  r[kRegPickFlags] = kPickGripper;
  r[kRegGroupsFound] = static_cast<std::uint16_t>(
      std::min<std::size_t>(std::max<std::size_t>(result.groups_found, result.groups.size()), 65535));
  r[kRegPickableBoxes] = result.pickable_boxes;
  std::uint16_t reported = 0;
  for (const GroupRecord& g : result.groups) {
    if (reported == kMaxGroups) break;
    if (!group_in_slots(g, reported_boxes)) continue;
    std::uint16_t* slot = r + kGroupStart + static_cast<std::ptrdiff_t>(kGroupStride) * reported;
    encode_pose(g, order, slot);
    slot[7] = g.box_count;
    slot[8] = g.first_box;
    slot[9] = g.pick_index;
    ++reported;
  }
  r[kRegGroupsReported] = reported;
  for (std::uint16_t i = 0; i < reported_boxes; ++i)
    r[kPickStatusStart + i] = static_cast<std::uint16_t>(result.boxes[i].pick_status);
}

}  // namespace

void encode_result(const ResultRecord& result, std::uint16_t result_id, WordOrder order,
                   RegisterImage& image) {
  clear_result(image);
  std::uint16_t* r = image.data();
  const auto reported = static_cast<std::uint16_t>(
      std::min<std::size_t>(result.boxes.size(), kMaxBoxes));
  r[kRegResultId] = result_id;
  r[kRegResultRequestId] = result.request_id;
  r[kRegResultStatus] = static_cast<std::uint16_t>(result.status);
  r[kRegBoxesFound] = std::max(result.boxes_found, reported);
  r[kRegBoxesReported] = reported;
  r[kRegRecipeUsed] = result.recipe;
  std::uint16_t flags = 0;
  if (result.ambiguous) flags |= kResAmbiguous;
  if (result.budget_exhausted) flags |= kResBudgetExhausted;
  if (result.layer_clipped) flags |= kResLayerClipped;
  if (result.outline_unobserved) flags |= kResOutlineUnobserved;
  if (result.height_off_layers) flags |= kResHeightOffLayers;
  if (result.formats_measured) flags |= kResFormatsMeasured;
  r[kRegResultFlags] = flags;
  r[kRegResultDetail] = static_cast<std::uint16_t>(result.detail);
  std::uint16_t layer_info = 0;
  if (result.height_above_pallet_m) {
    layer_info |= kLayerHeightKnown;
    put_i32(r + kRegHeightAbovePallet, metres_to_tenth_mm(*result.height_above_pallet_m), order);
  }
  if (result.layers_remaining) {
    layer_info |= kLayersRemainingKnown;
    r[kRegLayersRemaining] = static_cast<std::uint16_t>(std::clamp(*result.layers_remaining, 0, 65535));
  }
  r[kRegLayerInfoFlags] = layer_info;
  if (result.check) {
    r[kRegCheckResult] = static_cast<std::uint16_t>(result.check->result);
    r[kRegCheckBoxesGone] = result.check->boxes_gone;
    r[kRegCheckBoxesMoved] = result.check->boxes_moved;
    r[kRegCheckMovedSlot] = result.check->moved_slot;
    r[kRegCheckLargestMove] = static_cast<std::uint16_t>(
        std::clamp<std::int32_t>(metres_to_tenth_mm(result.check->largest_move_m), 0, 65535));
  }
  put_i32(r + kRegLayerZ, metres_to_tenth_mm(result.layer_z_m), order);
  r[kRegCoverage] = unit_to_permille(result.coverage);
  r[kRegLayoutConfidence] = unit_to_permille(result.layout_confidence);
  r[kRegBestRecipe] = result.best_recipe;
  for (std::uint16_t i = 0; i < reported; ++i) {
    const BoxRecord& b = result.boxes[i];
    std::uint16_t* slot = r + kBoxStart + static_cast<std::ptrdiff_t>(kBoxStride) * i;
    encode_pose(b, order, slot);
    slot[7] = b.format;
    slot[8] = unit_to_permille(b.score);
    slot[9] = b.pick_index;
    r[kSizeStart + kSizeStride * i] = tenth_mm_u16(b.long_m);
    r[kSizeStart + kSizeStride * i + 1] = tenth_mm_u16(b.short_m);
  }
  // A failed result has no boxes to pick (its record may still carry the detection's picks).
  if (result.picking && result.status != ResultStatus::kFailed) encode_picks(result, reported, order, r);
  r[kRegPickResultId] = result_id;
  r[kResultIdCopy] = result_id;
  r[kPickIdCopy] = result_id;
  r[kSizeIdCopy] = result_id;
}

ControlRecord decode_control(const RegisterImage& image) {
  ControlRecord c;
  c.control_word = image[kRegControlWord];
  c.recipe = image[kRegRecipe];
  c.request_id = image[kRegRequestId];
  c.plc_heartbeat = image[kRegPlcHeartbeat];
  return c;
}

namespace {


/// Registers 540..902 into `d` (the boxes are decoded already).
void decode_picks(const std::uint16_t* r, WordOrder order, DecodedResult& d) {
  d.pick_result_id = r[kRegPickResultId];
  d.pick_result_id_copy = r[kPickIdCopy];
  d.size_result_id_copy = r[kSizeIdCopy];
  ResultRecord& rec = d.record;
  rec.picking = (r[kRegPickFlags] & kPickGripper) != 0;
  rec.groups_found = r[kRegGroupsFound];
  rec.pickable_boxes = r[kRegPickableBoxes];
  const std::uint16_t reported = std::min<std::uint16_t>(r[kRegGroupsReported], kMaxGroups);
  for (std::uint16_t g = 0; g < reported; ++g) {
    const std::uint16_t* slot = r + kGroupStart + static_cast<std::ptrdiff_t>(kGroupStride) * g;
    GroupRecord group;
    decode_pose(slot, order, group);
    group.box_count = slot[7];
    group.first_box = slot[8];
    group.pick_index = slot[9];
    rec.groups.push_back(group);
  }
  for (std::size_t i = 0; i < rec.boxes.size(); ++i)
    rec.boxes[i].pick_status = static_cast<PickStatus>(r[kPickStatusStart + i]);
}

}  // namespace

DecodedResult decode_result(const RegisterImage& image, WordOrder order) {
  DecodedResult d;
  const std::uint16_t* r = image.data();
  d.result_id = r[kRegResultId];
  d.result_id_copy = r[kResultIdCopy];
  ResultRecord& rec = d.record;
  rec.request_id = r[kRegResultRequestId];
  rec.status = static_cast<ResultStatus>(r[kRegResultStatus]);
  rec.boxes_found = r[kRegBoxesFound];
  rec.recipe = r[kRegRecipeUsed];
  const std::uint16_t flags = r[kRegResultFlags];
  rec.ambiguous = (flags & kResAmbiguous) != 0;
  rec.budget_exhausted = (flags & kResBudgetExhausted) != 0;
  rec.layer_clipped = (flags & kResLayerClipped) != 0;
  rec.outline_unobserved = (flags & kResOutlineUnobserved) != 0;
  rec.height_off_layers = (flags & kResHeightOffLayers) != 0;
  rec.formats_measured = (flags & kResFormatsMeasured) != 0;
  rec.detail = static_cast<ResultDetail>(r[kRegResultDetail]);
  if ((r[kRegLayerInfoFlags] & kLayerHeightKnown) != 0)
    rec.height_above_pallet_m = tenth_mm_to_metres(get_i32(r + kRegHeightAbovePallet, order));
  if ((r[kRegLayerInfoFlags] & kLayersRemainingKnown) != 0) rec.layers_remaining = r[kRegLayersRemaining];
  if (r[kRegCheckResult] != 0) {
    CheckRecord c;
    c.result = static_cast<CheckResult>(r[kRegCheckResult]);
    c.boxes_gone = r[kRegCheckBoxesGone];
    c.boxes_moved = r[kRegCheckBoxesMoved];
    c.moved_slot = r[kRegCheckMovedSlot];
    c.largest_move_m = r[kRegCheckLargestMove] * 1e-4;
    rec.check = c;
  }
  rec.layer_z_m = tenth_mm_to_metres(get_i32(r + kRegLayerZ, order));
  rec.coverage = r[kRegCoverage] * 1e-3;
  rec.layout_confidence = r[kRegLayoutConfidence] * 1e-3;
  rec.best_recipe = r[kRegBestRecipe];
  const std::uint16_t reported = std::min<std::uint16_t>(r[kRegBoxesReported], kMaxBoxes);
  for (std::uint16_t i = 0; i < reported; ++i) {
    const std::uint16_t* slot = r + kBoxStart + static_cast<std::ptrdiff_t>(kBoxStride) * i;
    BoxRecord b;
    decode_pose(slot, order, b);
    b.format = slot[7];
    b.score = slot[8] * 1e-3;
    b.pick_index = slot[9];
    b.long_m = r[kSizeStart + kSizeStride * i] * 1e-4;
    b.short_m = r[kSizeStart + kSizeStride * i + 1] * 1e-4;
    rec.boxes.push_back(b);
  }
  decode_picks(r, order, d);
  return d;
}

StatusRecord decode_status(const RegisterImage& image, WordOrder order) {
  StatusRecord s;
  const std::uint16_t* r = image.data();
  s.status_word = r[kRegStatusWord];
  s.error = static_cast<ErrorCode>(r[kRegErrorCode]);
  s.error_detail = r[kRegErrorDetail];
  s.heartbeat = r[kRegHeartbeat];
  s.active_recipe = r[kRegActiveRecipe];
  s.acquisition_id = r[kRegAcquisitionId];
  s.result_id = r[kRegStatusResultId];
  s.last_request_id = r[kRegLastRequestId];
  s.poses_in_camera_frame = (r[kRegFormatFlags] & kFmtCameraFrame) != 0;
  s.missed_triggers = r[kRegMissedTriggers];
  s.processing_ms = r[kRegProcessingMs];
  s.latency_ms = r[kRegLatencyMs];
  s.frames_grabbed = get_u32(r + kRegFramesGrabbed, order);
  s.camera_reconnects = r[kRegCameraReconnects];
  CameraFaultCounters& f = s.camera_faults;
  f.incomplete_frames = get_u32(r + kRegIncompleteFrames, order);
  f.grab_timeouts = get_u32(r + kRegGrabTimeouts, order);
  f.dropped_frames = get_u32(r + kRegDroppedFrames, order);
  f.camera_losses = get_u32(r + kRegCameraLosses, order);
  f.camera_restarts = get_u32(r + kRegCameraRestarts, order);
  f.resent_packets = get_u32(r + kRegResentPackets, order);
  ConnectionCounters& c = s.connections;
  c.evicted = get_u32(r + kRegConnectionsEvicted, order);
  c.refused = get_u32(r + kRegConnectionsRefused, order);
  c.open = r[kRegOpenConnections];
  c.max_connections = r[kRegMaxConnections];
  HealthRecord& h = s.health;
  h.flags = r[kRegHealthFlags];
  h.frames = r[kRegHealthFrames];
  h.invalid_fraction = r[kRegInvalidPermille] / 1000.0;
  h.flying_fraction = r[kRegFlyingPermille] / 1000.0;
  h.saturated_fraction = r[kRegSaturatedPermille] / 1000.0;
  h.noise_ratio = r[kRegNoiseRatio] / 100.0;
  h.drift_shift_mm = r[kRegDriftShift] / 10.0;
  h.drift_angle_deg = r[kRegDriftAngle] / 100.0;
  return s;
}

}  // namespace palletd::modbus
