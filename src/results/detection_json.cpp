#include "palletd/results/detection_json.hpp"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "palletd/frames/files.hpp"

namespace palletd {


namespace {

using Json = nlohmann::ordered_json;

Json vec3(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

Json optional_number(const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); }

/// The frame's cell health (detection/health.hpp); null where a figure was not measured.
Json health_json(const FrameHealth& h) {
  return {{"roi_pixels", h.roi_pixels},
          {"invalid_fraction", h.invalid_fraction},
          {"saturated_fraction", optional_number(h.saturated_fraction)},
          {"flying_fraction", optional_number(h.flying_fraction)},
          {"plane_noise_mm", optional_number(h.plane_noise_mm)},
          {"model_noise_mm", optional_number(h.model_noise_mm)},
          {"noise_ratio", optional_number(h.noise_ratio)}};
}

/// A TCP pose (base frame when calibrated, else camera frame; shared/spec/detections.md).
Json tcp_json(const TcpPose& tcp) { return {{"position", vec3(tcp.position_m)}, {"yaw_deg", tcp.yaw_deg}}; }

Json groups_json(const std::vector<PickGroup>& groups) {
  Json out = Json::array();
  for (const PickGroup& g : groups) out.push_back({{"boxes", g.boxes}, {"tcp", tcp_json(g.tcp)}, {"pick_index", g.pick_index}});
  return out;
}

/// What a box's confidence is computed from (detection.hpp ScoreTerms).
Json score_terms_json(const ScoreTerms& t) {
  return {{"support", t.support},
          {"inside", t.inside},
          {"edge_seams", t.edge_seams},
          {"interior_seam", t.interior_seam},
          {"position_sigma_mm", t.position_sigma_mm},
          {"refine_shift_mm", t.refine_shift_mm},
          {"pitch_mm", t.pitch_mm},
          {"rim_share", t.rim_share},
          {"layout_formats", t.layout_formats},
          {"partly_unseen", t.partly_unseen},
          {"contested", t.contested},
          {"layout_ambiguous", t.layout_ambiguous},
          {"outline_unobserved", t.outline_unobserved}};
}

/// The recipe check: each format's measured sides and the recipe that fits (recipe_check.hpp).
Json recipe_check_json(const RecipeCheck& c) {
  auto mm = [](double m) { return m > 0.0 ? Json(1e3 * m) : Json(nullptr); };
  Json formats = Json::array();
  for (const FormatCheck& f : c.formats) {
    formats.push_back({{"format", f.format},
                       {"nominal_mm", {1e3 * f.nominal_long_m, 1e3 * f.nominal_short_m}},
                       {"measured_mm", {mm(f.measured_long_m), mm(f.measured_short_m)}},
                       {"boxes_measured", {f.boxes_long, f.boxes_short}},
                       {"row_bound_mm", {mm(f.run_long_m), mm(f.run_short_m)}},
                       {"boxes_tape_across", f.boxes_tape_across},
                       {"boxes_tape_halves", f.boxes_tape_halves},
                       {"agrees", f.agrees}});
  }
  return {{"checked", c.checked},
          {"agrees", c.agrees},
          {"formats", std::move(formats)},
          {"best_recipe", c.best_recipe ? Json(*c.best_recipe) : Json(nullptr)}};
}

}  // namespace

std::string detection_to_json_line(const Detection& detection, const std::string& frame_stem) {
  Json j;
  j["frame"] = frame_stem;
  j["status"] = to_string(detection.status);
  j["message"] = detection.message;
  Json timing = Json::object();
  const auto total = detection.timing_ms.find("total");
  timing["total"] = total != detection.timing_ms.end() ? total->second : 0.0;
  for (const auto& [stage, ms] : detection.timing_ms)
    if (stage != "total") timing[stage] = ms;
  j["timing_ms"] = std::move(timing);
  const Plane& p = detection.plane_camera;
  j["layer"] = {{"plane", {p.normal.x(), p.normal.y(), p.normal.z(), p.d}},
                {"area_m2", detection.layer_area_m2},
                {"coverage", detection.coverage},
                {"height_above_pallet_m", optional_number(detection.height_above_pallet_m)},
                {"seams_seen", detection.interior_seams.length_m > 0.0
                                   ? Json(detection.interior_seams.seen_share())
                                   : Json(nullptr)}};
  j["ambiguous"] = detection.ambiguous;
  j["ambiguity_reason"] = detection.ambiguity_reason;
  j["budget_exhausted"] = detection.budget_exhausted;
  j["clipped_by_image_border"] = detection.clipped_by_image_border;
  j["outline_unobserved"] = detection.outline_unobserved;
  j["layers_remaining"] = detection.layers_remaining ? Json(*detection.layers_remaining) : Json(nullptr);
  j["layout_confidence"] = detection.layout_confidence;
  if (!detection.recipe_check.formats.empty()) j["recipe_check"] = recipe_check_json(detection.recipe_check);
  if (detection.formats_measured) j["formats_measured"] = true;  // size-range recipe: format -1, size measured
  Json boxes = Json::array();
  for (const DetectedBox& b : detection.boxes) {
    Json box;
    box["center"] = vec3(b.center);
    box["long_axis"] = vec3(b.long_axis);
    box["normal"] = vec3(b.normal);
    box["size"] = {b.long_m, b.short_m};
    box["measured_size"] = {b.measured_long_m > 0 ? Json(b.measured_long_m) : Json(nullptr),
                            b.measured_short_m > 0 ? Json(b.measured_short_m) : Json(nullptr)};
    box["format"] = b.format;
    box["score"] = b.score;
    box["score_terms"] = score_terms_json(b.score_terms);
    box["partly_unseen"] = b.partly_unseen;
    if (b.base_position) {
      Json base;
      base["position"] = vec3(*b.base_position);
      base["yaw_deg"] = b.base_yaw_deg.value_or(0.0);
      box["base"] = std::move(base);
    }
    box["pick_index"] = b.pick_index;
    if (b.pick) {
      box["pickable"] = b.pick->pickable;
      box["blocked_by"] = to_string(b.pick->blocked_by);
      box["tcp"] = tcp_json(b.pick->tcp);
    }
    boxes.push_back(std::move(box));
  }
  j["boxes"] = std::move(boxes);
  const bool with_gripper = std::any_of(detection.boxes.begin(), detection.boxes.end(),
                                        [](const DetectedBox& b) { return b.pick.has_value(); });
  if (with_gripper) j["groups"] = groups_json(detection.groups);
  if (detection.health.measured) j["health"] = health_json(detection.health);
  // Non-finite numbers become null (JSON has no NaN); the parser reads null back as NaN.
  return j.dump();
}

namespace {

/// A finite number, or NaN for null (what dump() writes for NaN).
bool read_double(const nlohmann::json& v, double& out) {
  if (v.is_null()) {
    out = std::nan("");
    return true;
  }
  if (!v.is_number()) return false;
  out = v.get<double>();
  return true;
}

std::string read_vec(const nlohmann::json& v, const std::string& what, std::size_t n, double* out) {
  if (!v.is_array() || v.size() != n) return what + " must be an array of " + std::to_string(n) + " numbers";
  for (std::size_t i = 0; i < n; ++i)
    if (!read_double(v[i], out[i])) return what + " must be an array of " + std::to_string(n) + " numbers";
  return {};
}

std::string parse_box(const nlohmann::json& b, const std::string& where, ParsedBox& box) {
  if (!b.is_object()) return where + " must be an object";
  for (auto [key, out] : {std::pair<const char*, Eigen::Vector3d*>{"center", &box.center},
                          {"long_axis", &box.long_axis},
                          {"normal", &box.normal}}) {
    if (!b.contains(key)) return where + ": missing key '" + key + "'";
    if (auto e = read_vec(b[key], where + "." + key, 3, out->data()); !e.empty()) return e;
  }
  if (!b.contains("size")) return where + ": missing key 'size'";
  double size[2];
  if (auto e = read_vec(b["size"], where + ".size", 2, size); !e.empty()) return e;
  box.long_m = size[0];
  box.short_m = size[1];
  if (!b.contains("format") || !b["format"].is_number_integer()) return where + ".format must be an integer";
  box.format = b["format"].get<int>();
  if (b.contains("score") && !read_double(b["score"], box.score)) return where + ".score must be a number";
  if (b.contains("partly_unseen")) {
    if (!b["partly_unseen"].is_boolean()) return where + ".partly_unseen must be true or false";
    box.partly_unseen = b["partly_unseen"].get<bool>();
  }
  if (b.contains("pick_index")) {
    if (!b["pick_index"].is_number_integer()) return where + ".pick_index must be an integer";
    box.pick_index = b["pick_index"].get<int>();
  }
  if (b.contains("base")) {
    const nlohmann::json& base = b["base"];
    if (!base.is_object() || !base.contains("position")) return where + ".base must hold 'position'";
    Eigen::Vector3d position;
    if (auto e = read_vec(base["position"], where + ".base.position", 3, position.data()); !e.empty()) return e;
    box.base_position = position;
    if (base.contains("yaw_deg")) {
      double yaw = 0.0;
      if (!read_double(base["yaw_deg"], yaw)) return where + ".base.yaw_deg must be a number";
      box.base_yaw_deg = yaw;
    }
  }
  return {};
}

}  // namespace

Expected<ParsedDetection> parse_detection_line(const std::string& line) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(line);
  } catch (const nlohmann::json::parse_error& e) {
    return Error{"detection line is not valid JSON (byte " + std::to_string(e.byte) + ")"};
  }
  const auto fail = [](const std::string& problem) { return Expected<ParsedDetection>(Error{"detection line: " + problem}); };
  if (!j.is_object()) return fail("must be a JSON object");
  ParsedDetection d;
  if (auto e = io_detail::get_string(j, "frame", d.frame); !e.empty()) return fail(e);
  if (auto e = io_detail::get_string(j, "status", d.status); !e.empty()) return fail(e);
  if (j.contains("message")) {
    if (auto e = io_detail::get_string(j, "message", d.message); !e.empty()) return fail(e);
  }
  if (j.contains("timing_ms")) {
    if (!j["timing_ms"].is_object()) return fail("key 'timing_ms' must be an object");
    for (const auto& [stage, ms] : j["timing_ms"].items()) {
      if (!ms.is_number()) return fail("timing_ms." + stage + " must be a number");
      d.timing_ms[stage] = ms.get<double>();
    }
  }
  if (j.contains("layer")) {
    const nlohmann::json& layer = j["layer"];
    if (!layer.is_object()) return fail("key 'layer' must be an object");
    if (layer.contains("plane")) {
      double p[4];
      if (auto e = read_vec(layer["plane"], "layer.plane", 4, p); !e.empty()) return fail(e);
      d.plane.normal = Eigen::Vector3d(p[0], p[1], p[2]);
      d.plane.d = p[3];
    }
    if (layer.contains("area_m2") && !read_double(layer["area_m2"], d.area_m2))
      return fail("layer.area_m2 must be a number");
    if (layer.contains("coverage") && !read_double(layer["coverage"], d.coverage))
      return fail("layer.coverage must be a number");
    if (layer.contains("height_above_pallet_m") && !layer["height_above_pallet_m"].is_null()) {
      double h = 0.0;
      if (!read_double(layer["height_above_pallet_m"], h)) return fail("layer.height_above_pallet_m must be a number or null");
      d.height_above_pallet_m = h;
    }
  }
  if (j.contains("layers_remaining") && !j["layers_remaining"].is_null()) {
    if (!j["layers_remaining"].is_number_integer()) return fail("key 'layers_remaining' must be an integer or null");
    d.layers_remaining = j["layers_remaining"].get<int>();
  }
  if (j.contains("ambiguity_reason")) {
    if (auto e = io_detail::get_string(j, "ambiguity_reason", d.ambiguity_reason); !e.empty()) return fail(e);
  }
  if (j.contains("ambiguous")) {
    if (!j["ambiguous"].is_boolean()) return fail("key 'ambiguous' must be true or false");
    d.ambiguous = j["ambiguous"].get<bool>();
  }
  if (!j.contains("boxes")) return fail("missing key 'boxes'");
  if (!j["boxes"].is_array()) return fail("key 'boxes' must be an array");
  for (std::size_t i = 0; i < j["boxes"].size(); ++i) {
    ParsedBox box;
    if (auto e = parse_box(j["boxes"][i], "boxes[" + std::to_string(i) + "]", box); !e.empty()) return fail(e);
    d.boxes.push_back(std::move(box));
  }
  return d;
}

}  // namespace palletd
