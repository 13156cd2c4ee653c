#include "status_json.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "palletd/modbus/register_words.hpp"
#include "palletd/results/detection_json.hpp"

namespace palletd::web {

using modbus::error_name;
using modbus::error_sentence;
using modbus::status_bit_names;

namespace {

using modbus::ErrorCode;

Json bits_json(std::uint16_t word, const std::vector<std::string>& names) {
  Json bits = Json::array();
  for (std::size_t i = 0; i < names.size(); ++i)
    bits.push_back({{"bit", i}, {"name", names[i]}, {"set", (word & (1u << i)) != 0}});
  return bits;
}

Json optional_number(const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); }

/// The health window and the drift, for the page's camera panel.
Json cell_health_json(const CellHealth& h) {
  Json warnings = Json::array();
  const std::pair<std::uint16_t, const char*> names[] = {{modbus::kHealthInvalid, "invalid"},
                                                         {modbus::kHealthFlying, "flying"},
                                                         {modbus::kHealthSaturated, "saturated"},
                                                         {modbus::kHealthNoise, "noise"},
                                                         {modbus::kHealthDrift, "drift"}};
  for (const auto& [bit, name] : names)
    if ((h.warnings & bit) != 0) warnings.push_back(name);
  return {{"frames", h.frames},
          {"invalid_fraction", optional_number(h.invalid_fraction)},
          {"flying_fraction", optional_number(h.flying_fraction)},
          {"saturated_fraction", optional_number(h.saturated_fraction)},
          {"plane_noise_mm", optional_number(h.plane_noise_mm)},
          {"noise_ratio", optional_number(h.noise_ratio)},
          {"warnings", std::move(warnings)},
          {"drift", {{"reference", h.drift_reference},
                     {"measured", h.drift_measured},
                     {"shift_mm", h.drift_shift_mm},
                     {"angle_deg", h.drift_angle_deg},
                     {"note", h.drift_note}}}};
}

}  // namespace

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
  counters["warm_up_ms"] =
      optional_number(health.warm_up_ms >= 0.0 ? std::optional<double>(health.warm_up_ms) : std::nullopt);
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

  j["cell_health"] = cell_health_json(health.cell_health);

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

/// A pick check's findings: the verdict, and per box of the result checked against whether the
/// pick took it, whether it still stands, and how far it moved.
Json check_json(const PickCheck& check) {
  Json boxes = Json::array();
  for (const BoxCheck& c : check.boxes)
    boxes.push_back({{"box", c.box}, {"picked", c.picked}, {"present", c.present}, {"moved", c.moved},
                     {"shift_mm", c.shift_mm}, {"turn_deg", c.turn_deg}});
  return {{"verdict", to_string(check.verdict)}, {"message", check.message}, {"boxes", std::move(boxes)}};
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
  for (std::size_t i = 0; i < snapshot.detection.boxes.size(); ++i) {
    const DetectedBox& b = snapshot.detection.boxes[i];
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
    r["format_name"] = named ? recipe->formats[static_cast<std::size_t>(b.format)].name : (b.format < 0 ? "measured" : "");
    r["score"] = b.score;
    r["score_terms"] = j["boxes"][i]["score_terms"];  // shown on hover
    // With a gripper: whether the robot can take it now, else why not ("" without a gripper).
    r["pickable"] = b.pick ? Json(b.pick->pickable) : Json(nullptr);
    r["blocked_by"] = b.pick ? to_string(b.pick->blocked_by) : "";
    table.push_back(std::move(r));
  }
  j["table"] = std::move(table);
  j["check"] = snapshot.check ? check_json(*snapshot.check) : Json(nullptr);
  j["files"] = {{"overlay", "/api/overlay.png"},
                {"depth", "/api/frame/depth.png"},
                {"intensity", snapshot.frame && snapshot.frame->has_intensity() ? "/api/frame/intensity.png" : ""},
                {"meta", "/api/frame/meta.json"},
                {"detection", "/api/frame/detection.json"}};
  return j;
}

}  // namespace palletd::web
