// The register blocks as the status page shows them: addresses, raw words and their meaning.
#include <cstdio>
#include <utility>

#include "palletd/modbus/register_words.hpp"
#include "status_json.hpp"

namespace palletd::web {

using modbus::bits_in_words;
using modbus::control_bit_names;
using modbus::error_name;
using modbus::error_sentence;
using modbus::status_bit_names;

namespace {

using modbus::ErrorCode;

std::string hex16(std::uint16_t v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%04X", static_cast<unsigned>(v));
  return buf;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}



std::string ref4x(std::uint16_t address, int words) {
  std::string ref = std::to_string(40001 + address);
  if (words > 1) ref += "-" + std::to_string(40001 + address + words - 1);
  return ref;
}

Json row(const modbus::RegisterImage& image, std::uint16_t address, int words, const std::string& name,
         const std::string& value, const std::string& meaning) {
  Json raw = Json::array();
  for (int i = 0; i < words; ++i) raw.push_back(image[static_cast<std::size_t>(address + i)]);
  std::string addr = std::to_string(address);
  if (words > 1) addr += "-" + std::to_string(address + words - 1);
  return {{"address", addr}, {"ref", ref4x(address, words)}, {"name", name}, {"raw", raw}, {"value", value},
          {"meaning", meaning}};
}

std::string plain(const modbus::RegisterImage& image, std::uint16_t address) {
  return std::to_string(image[address]);
}

const char* result_status_text(std::uint16_t v) {
  switch (v) {
    case 0: return "ok: boxes found";
    case 1: return "no boxes";
    case 2: return "failed: see the error code (101)";
    default: return "unknown value";
  }
}



/// Rows of the control block 0..15 (what the PLC wrote).
Json control_rows(const modbus::RegisterImage& image) {
  const modbus::ControlRecord ctl = modbus::decode_control(image);
  Json control = Json::array();
  control.push_back(row(image, modbus::kRegControlWord, 1, "control word", hex16(ctl.control_word),
                        bits_in_words(ctl.control_word, control_bit_names())));
  control.push_back(row(image, modbus::kRegRecipe, 1, "recipe number", std::to_string(ctl.recipe), "recipe the PLC asks for"));
  control.push_back(row(image, modbus::kRegRequestId, 1, "request id", std::to_string(ctl.request_id), "echoed in 107 and 201"));
  control.push_back(row(image, modbus::kRegPlcHeartbeat, 1, "PLC heartbeat", std::to_string(ctl.plc_heartbeat),
                        "changed by the PLC (optional watch)"));
  return control;
}

/// Rows of the status block 100..129.
Json status_rows(const modbus::RegisterImage& image, modbus::WordOrder order) {
  const modbus::StatusRecord st = modbus::decode_status(image, order);
  Json status = Json::array();
  status.push_back(row(image, modbus::kRegStatusWord, 1, "status word", hex16(st.status_word),
                       bits_in_words(st.status_word, status_bit_names())));
  status.push_back(row(image, modbus::kRegErrorCode, 1, "error code", std::to_string(static_cast<unsigned>(st.error)),
                       error_name(st.error)));
  status.push_back(row(image, modbus::kRegErrorDetail, 1, "error detail", std::to_string(st.error_detail),
                       st.error == ErrorCode::kNone ? "-" : error_sentence(st.error, st.error_detail)));
  status.push_back(row(image, modbus::kRegHeartbeat, 1, "heartbeat", plain(image, modbus::kRegHeartbeat), "counts up at 1 Hz"));
  status.push_back(row(image, modbus::kRegActiveRecipe, 1, "active recipe", plain(image, modbus::kRegActiveRecipe), "recipe in force"));
  status.push_back(row(image, modbus::kRegAcquisitionId, 1, "acquisition id", plain(image, modbus::kRegAcquisitionId),
                       "frames acquired for triggers"));
  status.push_back(row(image, modbus::kRegStatusResultId, 1, "result id", plain(image, modbus::kRegStatusResultId),
                       "id of the newest result"));
  status.push_back(row(image, modbus::kRegLastRequestId, 1, "last request id", plain(image, modbus::kRegLastRequestId),
                       "request id latched with the last trigger"));
  const std::uint16_t version = image[modbus::kRegInterfaceVersion];
  status.push_back(row(image, modbus::kRegInterfaceVersion, 1, "interface version", std::to_string(version),
                       version == modbus::kInterfaceVersion ? "as documented" : "unexpected version"));
  const std::uint16_t fmt = image[modbus::kRegFormatFlags];
  status.push_back(row(image, modbus::kRegFormatFlags, 1, "format flags", hex16(fmt),
                       std::string((fmt & modbus::kFmtLowWordFirst) ? "low word first" : "high word first") +
                           ", poses in the " + ((fmt & modbus::kFmtCameraFrame) ? "camera frame" : "robot base frame")));
  const std::uint32_t pattern = modbus::get_u32(&image[modbus::kRegTestPattern], order);
  char pat[16];
  std::snprintf(pat, sizeof pat, "0x%08X", static_cast<unsigned>(pattern));
  status.push_back(row(image, modbus::kRegTestPattern, 2, "test pattern", pat,
                       pattern == modbus::kTestPattern ? "reads 0x12345678: word order right"
                                                       : "should read 0x12345678: check the word order"));
  status.push_back(row(image, modbus::kRegMissedTriggers, 1, "missed triggers", std::to_string(st.missed_triggers),
                       "triggers while busy"));
  status.push_back(row(image, modbus::kRegProcessingMs, 1, "processing time", fixed(st.processing_ms, 0) + " ms",
                       "last detection"));
  status.push_back(row(image, modbus::kRegLatencyMs, 1, "latency", fixed(st.latency_ms, 0) + " ms",
                       "last trigger to result"));
  status.push_back(row(image, modbus::kRegFramesGrabbed, 2, "frames grabbed", std::to_string(st.frames_grabbed),
                       "since start"));
  status.push_back(row(image, modbus::kRegCameraReconnects, 1, "camera reconnects", std::to_string(st.camera_reconnects),
                       "since start"));
  const modbus::CameraFaultCounters& faults = st.camera_faults;
  const struct {
    std::uint16_t reg;
    const char* name;
    std::uint32_t value;
    const char* meaning;
  } fault_rows[] = {
      {modbus::kRegIncompleteFrames, "incomplete frames", faults.incomplete_frames, "refused: missing packets, size"},
      {modbus::kRegGrabTimeouts, "grab timeouts", faults.grab_timeouts, "no frame in time (stalled camera)"},
      {modbus::kRegDroppedFrames, "dropped frames", faults.dropped_frames, "lost before palletd saw them"},
      {modbus::kRegCameraLosses, "camera losses", faults.camera_losses, "camera found gone"},
      {modbus::kRegCameraRestarts, "camera restarts", faults.camera_restarts, "stalled camera restarted"},
      {modbus::kRegResentPackets, "resent packets", faults.resent_packets, "GigE Vision packets resent"},
  };
  for (const auto& r : fault_rows)
    status.push_back(row(image, r.reg, 2, r.name, std::to_string(r.value), std::string(r.meaning) + ", since start"));
  return status;
}

/// Rows of the Modbus connection block 140..145.
Json connection_rows(const modbus::RegisterImage& image, modbus::WordOrder order) {
  const modbus::ConnectionCounters c = modbus::decode_status(image, order).connections;
  Json rows = Json::array();
  rows.push_back(row(image, modbus::kRegConnectionsEvicted, 2, "connections evicted", std::to_string(c.evicted),
                     c.evicted == 0 ? "none since start" : "closed at the cap: more clients poll than max_connections"));
  rows.push_back(row(image, modbus::kRegConnectionsRefused, 2, "connections refused", std::to_string(c.refused),
                     "not on modbus.allow, since start"));
  rows.push_back(row(image, modbus::kRegOpenConnections, 1, "open connections", std::to_string(c.open), "now"));
  rows.push_back(row(image, modbus::kRegMaxConnections, 1, "connection cap", std::to_string(c.max_connections),
                     "modbus.max_connections"));
  return rows;
}

/// Rows of the cell health block 146..153.
Json health_rows(const modbus::RegisterImage& image, modbus::WordOrder order) {
  const modbus::HealthRecord h = modbus::decode_status(image, order).health;
  std::string flags;
  const std::pair<std::uint16_t, const char*> names[] = {
      {modbus::kHealthInvalid, "no depth"},          {modbus::kHealthFlying, "flying pixels"},
      {modbus::kHealthSaturated, "saturated"},       {modbus::kHealthNoise, "plane noise"},
      {modbus::kHealthDrift, "drift"},               {modbus::kHealthDriftReference, "reference loaded"},
      {modbus::kHealthDriftMeasured, "drift measured"}};
  for (const auto& [bit, name] : names)
    if ((h.flags & bit) != 0) flags += std::string(name) + "; ";
  if (!flags.empty()) flags.resize(flags.size() - 2);
  Json rows = Json::array();
  rows.push_back(row(image, modbus::kRegHealthFlags, 1, "health flags", hex16(h.flags), flags.empty() ? "none set" : flags));
  rows.push_back(row(image, modbus::kRegHealthFrames, 1, "health window", std::to_string(h.frames), "frames"));
  rows.push_back(row(image, modbus::kRegInvalidPermille, 1, "no depth", fixed(h.invalid_fraction * 100.0, 1) + " %",
                     "of the region of interest's pixels"));
  rows.push_back(row(image, modbus::kRegFlyingPermille, 1, "flying pixels", fixed(h.flying_fraction * 100.0, 1) + " %",
                     "of those at the layer's edges"));
  rows.push_back(row(image, modbus::kRegSaturatedPermille, 1, "saturated", fixed(h.saturated_fraction * 100.0, 1) + " %",
                     "of the region of interest's pixels"));
  rows.push_back(row(image, modbus::kRegNoiseRatio, 1, "noise ratio", fixed(h.noise_ratio, 2), "plane noise / model, 0 = no model"));
  rows.push_back(row(image, modbus::kRegDriftShift, 1, "drift shift", fixed(h.drift_shift_mm, 1) + " mm", "against the reference"));
  rows.push_back(row(image, modbus::kRegDriftAngle, 1, "drift angle", fixed(h.drift_angle_deg, 2) + " deg", "against the reference"));
  return rows;
}

/// Rows 135..139: what the pick check this result answers found.
void check_rows(const modbus::RegisterImage& image, const modbus::ResultRecord& rec, Json& rows) {
  static const char* const kWords[] = {"- (a detection's result)", "pick_ok", "box_still_there", "extra_box_gone",
                                       "neighbour_moved"};
  const std::uint16_t code = image[modbus::kRegCheckResult];
  rows.push_back(row(image, modbus::kRegCheckResult, 1, "pick check", plain(image, modbus::kRegCheckResult),
                     code < 5 ? kWords[code] : "unknown value"));
  if (!rec.check) return;
  rows.push_back(row(image, modbus::kRegCheckBoxesGone, 1, "boxes gone", plain(image, modbus::kRegCheckBoxesGone),
                     "since the result checked against"));
  rows.push_back(row(image, modbus::kRegCheckBoxesMoved, 1, "boxes moved", plain(image, modbus::kRegCheckBoxesMoved),
                     "their slots hold the new poses"));
  rows.push_back(row(image, modbus::kRegCheckMovedSlot, 1, "moved most", plain(image, modbus::kRegCheckMovedSlot),
                     "slot + 1 (0 = none)"));
  rows.push_back(row(image, modbus::kRegCheckLargestMove, 1, "its move", fixed(rec.check->largest_move_m * 1000.0, 1) + " mm",
                     ""));
}

/// Rows of the result block 200..209 and 530, and of its extension 130..139.
Json result_rows(const modbus::RegisterImage& image, const modbus::DecodedResult& res) {
  const modbus::ResultRecord& rec = res.record;
  Json result = Json::array();
  result.push_back(row(image, modbus::kRegResultId, 1, "result id", std::to_string(res.result_id), "0 = no result yet"));
  result.push_back(row(image, modbus::kRegResultRequestId, 1, "request id echo", std::to_string(rec.request_id),
                       "request id of the trigger this answers"));
  result.push_back(row(image, modbus::kRegResultStatus, 1, "result status", plain(image, modbus::kRegResultStatus),
                       result_status_text(image[modbus::kRegResultStatus])));
  result.push_back(row(image, modbus::kRegBoxesFound, 1, "boxes found", std::to_string(rec.boxes_found), "in the layer"));
  result.push_back(row(image, modbus::kRegBoxesReported, 1, "boxes reported", plain(image, modbus::kRegBoxesReported),
                       "in slots 210 + 10 i (at most 32)"));
  result.push_back(row(image, modbus::kRegRecipeUsed, 1, "recipe used", std::to_string(rec.recipe), ""));
  std::string flags;
  if (rec.ambiguous) flags += "ambiguous layout; ";
  if (rec.budget_exhausted) flags += "search budget exhausted; ";
  if (rec.layer_clipped) flags += "layer clipped by the image border; ";
  if (rec.outline_unobserved) flags += "outline partly unobserved (the layer may go on where the depth ends); ";
  if (rec.height_off_layers) flags += "height not a whole number of box heights; ";
  if (rec.formats_measured) flags += "sizes measured on the frame (size-range recipe, formats 0xFFFF); ";
  if (!flags.empty()) flags.resize(flags.size() - 2);
  result.push_back(row(image, modbus::kRegResultFlags, 1, "result flags", hex16(image[modbus::kRegResultFlags]),
                       flags.empty() ? "none set" : flags));
  result.push_back(row(image, modbus::kRegLayerZ, 2, "layer height z", fixed(rec.layer_z_m * 1000.0, 1) + " mm", ""));
  result.push_back(row(image, modbus::kRegCoverage, 1, "coverage", fixed(rec.coverage * 100.0, 1) + " %",
                       "layer area covered by the boxes"));
  const char* detail = rec.detail == modbus::ResultDetail::kEmpty         ? "empty pallet"
                       : rec.detail == modbus::ResultDetail::kSlipSheet   ? "slip sheet: remove it"
                       : rec.detail == modbus::ResultDetail::kLayerPicked ? "layer picked: trigger for the next level"
                                                                           : "-";
  result.push_back(row(image, modbus::kRegResultDetail, 1, "result detail", plain(image, modbus::kRegResultDetail), detail));
  result.push_back(row(image, modbus::kRegHeightAbovePallet, 2, "height above pallet",
                       rec.height_above_pallet_m ? fixed(*rec.height_above_pallet_m * 1000.0, 1) + " mm" : "-",
                       rec.height_above_pallet_m ? "" : "needs pallet.top_z_m and camera_to_base"));
  result.push_back(row(image, modbus::kRegLayersRemaining, 1, "layers left",
                       rec.layers_remaining ? std::to_string(*rec.layers_remaining) : "-",
                       rec.layers_remaining ? "counting the top layer" : "needs the formats' height_mm too"));
  check_rows(image, rec, result);
  result.push_back(row(image, modbus::kResultIdCopy, 1, "result id copy", std::to_string(res.result_id_copy),
                       res.result_id_copy == res.result_id ? "matches 200" : "differs from 200: torn read"));
  result.push_back(row(image, modbus::kRegLayoutConfidence, 1, "layout confidence",
                       fixed(rec.layout_confidence, 3), "estimated probability that every box is right"));
  result.push_back(row(image, modbus::kRegBestRecipe, 1, "best-fitting recipe",
                       rec.best_recipe != 0 ? std::to_string(rec.best_recipe) : "-",
                       rec.best_recipe != 0 ? "the frame shows this recipe's cartons" : "set with a recipe mismatch"));
  return result;
}

/// The JSON word of a box slot's pick status (register 870 + i).
const char* pick_status_word(modbus::PickStatus status) {
  switch (status) {
    case modbus::PickStatus::kPickable: return "pickable";
    case modbus::PickStatus::kRoi: return "roi";
    case modbus::PickStatus::kHigherLevel: return "higher_level";
    case modbus::PickStatus::kYawLimits: return "yaw_limits";
    case modbus::PickStatus::kNeighbour: return "neighbour";
  }
  return "unknown value";
}

/// One row per reported group (550 + 10 g): the TCP, and which box slots the pick takes.
void group_rows(const modbus::RegisterImage& image, const modbus::ResultRecord& rec, Json& rows) {
  for (std::size_t g = 0; g < rec.groups.size(); ++g) {
    const modbus::GroupRecord& grp = rec.groups[g];
    const auto address = static_cast<std::uint16_t>(modbus::kGroupStart + modbus::kGroupStride * g);
    const std::string tcp = "(" + fixed(grp.x_m * 1000.0, 1) + ", " + fixed(grp.y_m * 1000.0, 1) + ", " +
                            fixed(grp.z_m * 1000.0, 1) + ") mm, " + fixed(grp.yaw_deg, 2) + " deg";
    const int last = grp.first_box + grp.box_count - 1;
    const std::string slots = grp.box_count > 1 ? "slots " + std::to_string(grp.first_box) + "-" + std::to_string(last)
                                                : "slot " + std::to_string(grp.first_box);
    rows.push_back(row(image, address, modbus::kGroupStride, "group " + std::to_string(g), tcp,
                       "pick " + std::to_string(grp.pick_index) + ": the TCP for box " + slots));
  }
}

/// One row for the reported box slots' pick statuses (870 + i): the blocked slots by name.
void box_pick_row(const modbus::RegisterImage& image, const modbus::ResultRecord& rec, Json& rows) {
  if (!rec.picking || rec.boxes.empty()) return;
  std::size_t pickable = 0;
  std::string blocked;
  for (std::size_t i = 0; i < rec.boxes.size(); ++i) {
    const modbus::PickStatus status = rec.boxes[i].pick_status;
    if (status == modbus::PickStatus::kPickable) {
      ++pickable;
    } else {
      blocked += "slot " + std::to_string(i) + " " + pick_status_word(status) + "; ";
    }
  }
  if (!blocked.empty()) blocked.resize(blocked.size() - 2);
  rows.push_back(row(image, modbus::kPickStatusStart, static_cast<int>(rec.boxes.size()), "box pick status",
                     std::to_string(pickable) + " of " + std::to_string(rec.boxes.size()) + " pickable",
                     blocked.empty() ? "every reported box pickable" : blocked));
}

/// Rows of the pick block 540..902 (header 540..544, the reported groups, the box slots' pick
/// statuses, the result id copy in 902) and of the size block 910..974.
Json pick_rows(const modbus::RegisterImage& image, const modbus::DecodedResult& res) {
  const modbus::ResultRecord& rec = res.record;
  Json rows = Json::array();
  rows.push_back(row(image, modbus::kRegPickResultId, 1, "pick result id", std::to_string(res.pick_result_id),
                     res.pick_result_id == res.result_id ? "matches 200" : "differs from 200: torn read"));
  rows.push_back(row(image, modbus::kRegPickFlags, 1, "pick flags", hex16(image[modbus::kRegPickFlags]),
                     rec.picking ? "gripper configured: pick data valid" : "no pick data (no gripper or no boxes)"));
  rows.push_back(row(image, modbus::kRegGroupsFound, 1, "groups found", std::to_string(rec.groups_found),
                     "picks the robot can make now"));
  rows.push_back(row(image, modbus::kRegGroupsReported, 1, "groups reported", plain(image, modbus::kRegGroupsReported),
                     "in 550 + 10 g (those within the reported box slots)"));
  rows.push_back(row(image, modbus::kRegPickableBoxes, 1, "pickable boxes", std::to_string(rec.pickable_boxes),
                     "among all boxes found"));
  group_rows(image, rec, rows);
  box_pick_row(image, rec, rows);
  rows.push_back(row(image, modbus::kPickIdCopy, 1, "pick result id copy", std::to_string(res.pick_result_id_copy),
                     res.pick_result_id_copy == res.result_id ? "matches 200" : "differs from 200: torn read"));
  if (!rec.boxes.empty()) {
    const modbus::BoxRecord& b = rec.boxes.front();
    rows.push_back(row(image, modbus::kSizeStart, modbus::kSizeStride * static_cast<int>(rec.boxes.size()), "box sizes",
                       "slot 0: " + fixed(b.long_m * 1000.0, 1) + " x " + fixed(b.short_m * 1000.0, 1) + " mm",
                       rec.formats_measured ? "measured on the frame" : "the recipe's formats"));
  }
  rows.push_back(row(image, modbus::kSizeIdCopy, 1, "size result id copy", std::to_string(res.size_result_id_copy),
                     res.size_result_id_copy == res.result_id ? "matches 200" : "differs from 200: torn read"));
  return rows;
}

/// One row per reported box slot (210 + 10 i).
Json box_rows(const modbus::ResultRecord& rec) {
  Json boxes = Json::array();
  for (std::size_t i = 0; i < rec.boxes.size(); ++i) {
    const modbus::BoxRecord& b = rec.boxes[i];
    boxes.push_back({{"slot", i},
                     {"address", modbus::kBoxStart + modbus::kBoxStride * i},
                     {"ref", ref4x(static_cast<std::uint16_t>(modbus::kBoxStart + modbus::kBoxStride * i),
                                   modbus::kBoxStride)},
                     {"x_mm", b.x_m * 1000.0},
                     {"y_mm", b.y_m * 1000.0},
                     {"z_mm", b.z_m * 1000.0},
                     {"yaw_deg", b.yaw_deg},
                     {"format", b.format},
                     {"score", b.score},
                     {"pick_index", b.pick_index}});
  }
  return boxes;
}

}  // namespace

Json registers_json(const modbus::RegisterImage& image, modbus::WordOrder order) {
  const modbus::DecodedResult res = modbus::decode_result(image, order);
  const Json control = control_rows(image);
  const Json status = status_rows(image, order);
  Json result = result_rows(image, res);
  for (Json& r : pick_rows(image, res)) result.push_back(std::move(r));
  const Json boxes = box_rows(res.record);
  Json out;
  out["word_order"] = order == modbus::WordOrder::kLowWordFirst ? "low word first" : "high word first";
  out["blocks"] = Json::array(
      {Json{{"name", "control"}, {"title", "Control block 0-15 (written by the PLC)"}, {"rows", control}},
       Json{{"name", "status"}, {"title", "Status block 100-129 (read-only)"}, {"rows", status}},
       Json{{"name", "result"}, {"title", "Result block 200-209, 530, its extension 130-139 and the pick block 540-902 (read-only)"}, {"rows", result}},
       Json{{"name", "connections"}, {"title", "Modbus connections 140-145 (read-only)"},
            {"rows", connection_rows(image, order)}},
       Json{{"name", "health"}, {"title", "Cell health 146-155 (read-only)"}, {"rows", health_rows(image, order)}}});
  out["boxes"] = boxes;
  return out;
}

}  // namespace palletd::web
