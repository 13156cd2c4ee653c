#include "status_json.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "palletd/modbus/register_words.hpp"
#include "palletd/results/detection_json.hpp"

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



Json bits_json(std::uint16_t word, const std::vector<std::string>& names) {
  Json bits = Json::array();
  for (std::size_t i = 0; i < names.size(); ++i)
    bits.push_back({{"bit", i}, {"name", names[i]}, {"set", (word & (1u << i)) != 0}});
  return bits;
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


}  // namespace

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

/// Rows of the result block 200..209 and 530, and of its extension 130..134.
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
  if (!flags.empty()) flags.resize(flags.size() - 2);
  result.push_back(row(image, modbus::kRegResultFlags, 1, "result flags", hex16(image[modbus::kRegResultFlags]),
                       flags.empty() ? "none set" : flags));
  result.push_back(row(image, modbus::kRegLayerZ, 2, "layer height z", fixed(rec.layer_z_m * 1000.0, 1) + " mm", ""));
  result.push_back(row(image, modbus::kRegCoverage, 1, "coverage", fixed(rec.coverage * 100.0, 1) + " %",
                       "layer area covered by the boxes"));
  const char* detail = rec.detail == modbus::ResultDetail::kEmpty       ? "empty pallet"
                       : rec.detail == modbus::ResultDetail::kSlipSheet ? "slip sheet: remove it"
                                                                         : "-";
  result.push_back(row(image, modbus::kRegResultDetail, 1, "result detail", plain(image, modbus::kRegResultDetail), detail));
  result.push_back(row(image, modbus::kRegHeightAbovePallet, 2, "height above pallet",
                       rec.height_above_pallet_m ? fixed(*rec.height_above_pallet_m * 1000.0, 1) + " mm" : "-",
                       rec.height_above_pallet_m ? "" : "needs pallet.top_z_m and camera_to_base"));
  result.push_back(row(image, modbus::kRegLayersRemaining, 1, "layers left",
                       rec.layers_remaining ? std::to_string(*rec.layers_remaining) : "-",
                       rec.layers_remaining ? "counting the top layer" : "needs the formats' height_mm too"));
  result.push_back(row(image, modbus::kResultIdCopy, 1, "result id copy", std::to_string(res.result_id_copy),
                       res.result_id_copy == res.result_id ? "matches 200" : "differs from 200: torn read"));
  return result;
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

Json registers_json(const modbus::RegisterImage& image, modbus::WordOrder order) {
  const modbus::DecodedResult res = modbus::decode_result(image, order);
  const Json control = control_rows(image);
  const Json status = status_rows(image, order);
  const Json result = result_rows(image, res);
  const Json boxes = box_rows(res.record);
  Json out;
  out["word_order"] = order == modbus::WordOrder::kLowWordFirst ? "low word first" : "high word first";
  out["blocks"] = Json::array(
      {Json{{"name", "control"}, {"title", "Control block 0-15 (written by the PLC)"}, {"rows", control}},
       Json{{"name", "status"}, {"title", "Status block 100-129 (read-only)"}, {"rows", status}},
       Json{{"name", "result"}, {"title", "Result block 200-209, 530 and its extension 130-134 (read-only)"}, {"rows", result}},
       Json{{"name", "connections"}, {"title", "Modbus connections 140-145 (read-only)"},
            {"rows", connection_rows(image, order)}}});
  out["boxes"] = boxes;
  return out;
}

std::string iso_time(std::chrono::system_clock::time_point t) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
  const std::time_t secs = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[96];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
                tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms % 1000));
  return buf;
}

std::string snapshot_stem(const ResultSnapshot& snapshot) {
  std::string camera = snapshot.frame ? snapshot.frame->camera_id : std::string();
  for (char& c : camera)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) c = '_';
  std::string stem = "palletd";
  if (!camera.empty()) stem += "-" + camera;
  return stem + "-" + std::to_string(snapshot.trigger_seq);
}

namespace {

const RecipeInfo* find_recipe(const std::vector<RecipeInfo>& recipes, int number) {
  for (const auto& r : recipes)
    if (r.number == number) return &r;
  return nullptr;
}

Json recipe_json(const RecipeInfo* recipe, int number) {
  Json j;
  j["number"] = number;
  j["name"] = recipe ? recipe->name : "";
  Json formats = Json::array();
  if (recipe) {
    for (std::size_t i = 0; i < recipe->formats.size(); ++i) {
      const BoxFormat& f = recipe->formats[i];
      formats.push_back({{"index", i},
                         {"name", f.name},
                         {"long_mm", std::round(f.long_m * 10000.0) / 10.0},
                         {"short_mm", std::round(f.short_m * 10000.0) / 10.0}});
    }
  }
  j["formats"] = formats;
  j["known"] = recipe != nullptr;
  return j;
}

Json optional_number(const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); }

}  // namespace

Json status_json(const ServiceHealth& health, const modbus::RegisterImage& image, modbus::WordOrder order,
                 const ResultSnapshot* latest, const std::vector<RecipeInfo>& recipes, const Figures& figures,
                 bool snapshot_post_allowed, int refresh_ms) {
  const modbus::StatusRecord st = modbus::decode_status(image, order);
  Json j;
  j["time"] = iso_time(std::chrono::system_clock::now());
  j["refresh_ms"] = refresh_ms;

  std::string state;
  if ((st.status_word & modbus::kStError) != 0) state = "error";
  else if ((st.status_word & modbus::kStBusy) != 0) state = "busy";
  else if ((st.status_word & modbus::kStReady) != 0) state = "ready";
  else state = "not ready";
  Json status;
  status["state"] = state;
  status["word"] = st.status_word;
  status["bits"] = bits_json(st.status_word, status_bit_names());
  status["error_code"] = static_cast<unsigned>(st.error);
  status["error_detail"] = st.error_detail;
  status["error"] = error_name(st.error);
  status["error_text"] = st.error == ErrorCode::kNone ? "" : error_sentence(st.error, st.error_detail);
  status["threads_alive"] = health.threads_alive;
  status["poses_in"] = st.poses_in_camera_frame ? "camera" : "base";
  j["status"] = status;

  j["camera"] = {{"id", health.camera_id}, {"state", health.camera_state}, {"ok", health.camera_ok}};

  Json counters;
  counters["triggers"] = health.triggers;
  counters["results"] = health.results;
  counters["failures"] = health.failures;
  counters["missed"] = st.missed_triggers;
  counters["reconnects"] = health.reconnects;
  counters["frames"] = health.frames;
  counters["incomplete_frames"] = health.incomplete_frames;
  counters["grab_timeouts"] = health.grab_timeouts;
  counters["dropped_frames"] = health.dropped_frames;
  counters["camera_losses"] = health.camera_losses;
  counters["camera_restarts"] = health.camera_restarts;
  counters["resent_packets"] = health.resent_packets;
  counters["window"] = figures.window;
  counters["processing_ms"] = {{"last", st.processing_ms},
                               {"p50", optional_number(figures.processing_p50_ms)},
                               {"p99", optional_number(figures.processing_p99_ms)}};
  counters["latency_ms"] = {{"last", st.latency_ms},
                            {"p50", optional_number(figures.latency_p50_ms)},
                            {"p99", optional_number(figures.latency_p99_ms)}};
  j["counters"] = counters;
  j["shadow"] = {{"enabled", health.shadow_enabled},
                 {"runs", health.shadow_runs},
                 {"disagreements", health.shadow_disagreements},
                 {"skipped", health.shadow_skipped},
                 {"last_difference", health.last_shadow_difference}};

  const int active = st.active_recipe;
  j["recipe"] = recipe_json(find_recipe(recipes, active), active);
  j["modbus"] = {{"port", health.modbus_port}, {"connections", health.modbus_connections}};
  j["registers"] = registers_json(image, order);

  if (latest != nullptr) {
    j["last_result"] = {{"trigger_seq", latest->trigger_seq},
                        {"request_id", latest->request_id},
                        {"recipe", latest->recipe},
                        {"status", to_string(latest->detection.status)},
                        {"boxes", latest->detection.boxes.size()},
                        {"error", error_name(latest->error)},
                        {"error_text", latest->error_text},
                        {"time", iso_time(latest->time)},
                        {"has_frame", latest->frame != nullptr}};
  } else {
    j["last_result"] = nullptr;
  }
  j["snapshot_post_allowed"] = snapshot_post_allowed;
  return j;
}

Json result_json(const ResultSnapshot& snapshot, const std::string& stem, const std::vector<RecipeInfo>& recipes) {
  Json j = Json::parse(detection_to_json_line(snapshot.detection, stem));
  const RecipeInfo* recipe = find_recipe(recipes, snapshot.recipe);
  bool base = !snapshot.detection.boxes.empty();
  for (const auto& b : snapshot.detection.boxes) base = base && b.base_position.has_value();
  j["poses_in"] = base ? "base" : "camera";
  j["trigger"] = {{"seq", snapshot.trigger_seq},
                  {"request_id", snapshot.request_id},
                  {"recipe", snapshot.recipe},
                  {"error_code", static_cast<unsigned>(snapshot.error)},
                  {"error", error_name(snapshot.error)},
                  {"error_text", snapshot.error_text},
                  {"latency_ms", snapshot.latency_ms},
                  {"time", iso_time(snapshot.time)}};
  j["recipe"] = recipe_json(recipe, snapshot.recipe);

  // The rows of the page's box table: pose in the base frame when known, else the camera frame.
  Json table = Json::array();
  for (const auto& b : snapshot.detection.boxes) {
    Json r;
    r["pick_index"] = b.pick_index;
    const bool in_base = b.base_position.has_value();
    const Eigen::Vector3d p = in_base ? *b.base_position : b.center;
    const double yaw = in_base ? b.base_yaw_deg.value_or(0.0)
                               : std::atan2(b.long_axis.y(), b.long_axis.x()) * (180.0 / 3.14159265358979323846);
    r["frame"] = in_base ? "base" : "camera";
    r["x_mm"] = p.x() * 1000.0;
    r["y_mm"] = p.y() * 1000.0;
    r["z_mm"] = p.z() * 1000.0;
    r["yaw_deg"] = yaw;
    r["long_mm"] = b.long_m * 1000.0;
    r["short_mm"] = b.short_m * 1000.0;
    r["format"] = b.format;
    const bool named = recipe != nullptr && b.format >= 0 &&
                       static_cast<std::size_t>(b.format) < recipe->formats.size();
    r["format_name"] = named ? recipe->formats[static_cast<std::size_t>(b.format)].name : "";
    r["score"] = b.score;
    table.push_back(std::move(r));
  }
  j["table"] = std::move(table);
  j["files"] = {{"overlay", "/api/overlay.png"},
                {"depth", "/api/frame/depth.png"},
                {"intensity", snapshot.frame && snapshot.frame->has_intensity() ? "/api/frame/intensity.png" : ""},
                {"meta", "/api/frame/meta.json"},
                {"detection", "/api/frame/detection.json"}};
  return j;
}

}  // namespace palletd::web
