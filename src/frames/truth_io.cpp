// STEM.truth.json (shared/spec/frames.md): ground truth for evaluation code and the simulator.
#include <cmath>

#include "palletd/frames/files.hpp"
#include "palletd/frames/frame_io.hpp"

namespace palletd {

using io_detail::get_numbers;

namespace {

const char* const kTruthSuffix = ".truth.json";

std::string read_vector3(const nlohmann::json& box, const char* key, const std::string& where,
                         Eigen::Vector3d& out) {
  const auto it = box.find(key);
  if (it == box.end()) return where + ": missing key '" + key + "'";
  return get_numbers(*it, where + "." + key, 3, out.data());
}

nlohmann::ordered_json vector_json(const Eigen::Vector3d& v) { return nlohmann::ordered_json::array({v.x(), v.y(), v.z()}); }

}  // namespace

Expected<Truth> read_truth(const std::string& stem) {
  const std::string path = stem + kTruthSuffix;
  auto doc = io_detail::parse_json_file(path);
  if (!doc) return Error{doc.error()};
  const nlohmann::json& j = *doc;
  const auto fail = [&](const std::string& problem) { return Expected<Truth>(Error{path + ": " + problem}); };
  if (!j.is_object()) return fail("must contain a JSON object");

  Truth truth;
  const auto boxes = j.find("boxes");
  if (boxes == j.end()) return fail("missing key 'boxes'");
  if (!boxes->is_array()) return fail("key 'boxes' must be an array");
  for (std::size_t i = 0; i < boxes->size(); ++i) {
    const nlohmann::json& b = (*boxes)[i];
    const std::string where = "boxes[" + std::to_string(i) + "]";
    if (!b.is_object()) return fail(where + " must be an object");
    TruthBox box;
    for (auto [key, out] : {std::pair<const char*, Eigen::Vector3d*>{"center", &box.center},
                            {"long_axis", &box.long_axis},
                            {"normal", &box.normal}}) {
      if (auto e = read_vector3(b, key, where, *out); !e.empty()) return fail(e);
    }
    const auto size = b.find("size");
    if (size == b.end()) return fail(where + ": missing key 'size'");
    double lengths[2];
    if (auto e = get_numbers(*size, where + ".size", 2, lengths); !e.empty()) return fail(e);
    box.long_m = lengths[0];
    box.short_m = lengths[1];
    if (b.contains("format")) {
      if (!b["format"].is_string()) return fail(where + ".format must be a string");
      box.format = b["format"].get<std::string>();
    }
    truth.boxes.push_back(std::move(box));
  }

  if (const auto it = j.find("layer_plane"); it != j.end()) {
    double p[4];
    if (auto e = get_numbers(*it, "'layer_plane'", 4, p); !e.empty()) return fail(e);
    truth.layer_plane.normal = Eigen::Vector3d(p[0], p[1], p[2]);
    truth.layer_plane.d = p[3];
  }
  if (const auto it = j.find("recipe"); it != j.end()) {
    if (!it->is_array()) return fail("key 'recipe' must be an array of format names");
    for (const auto& name : *it) {
      if (!name.is_string()) return fail("key 'recipe' must be an array of format names");
      truth.recipe.push_back(name.get<std::string>());
    }
  }
  if (const auto it = j.find("recipe_mm"); it != j.end()) {
    if (!it->is_array()) return fail("key 'recipe_mm' must be an array of [long, short] pairs");
    for (const auto& pair : *it) {
      double mm[2];
      if (auto e = get_numbers(pair, "each entry of 'recipe_mm'", 2, mm); !e.empty()) return fail(e);
      truth.recipe_mm.push_back({static_cast<int>(std::lround(mm[0])), static_cast<int>(std::lround(mm[1]))});
    }
  }
  if (const auto it = j.find("expect"); it != j.end()) {
    if (!it->is_string()) return fail("key 'expect' must be a string (boxes, empty, slip_sheet)");
    truth.expect = it->get<std::string>();
  }
  return truth;
}

Status write_truth(const std::string& stem, const Truth& truth) {
  nlohmann::ordered_json j;
  nlohmann::ordered_json boxes = nlohmann::ordered_json::array();
  for (const TruthBox& b : truth.boxes) {
    nlohmann::ordered_json box;
    box["center"] = vector_json(b.center);
    box["long_axis"] = vector_json(b.long_axis);
    box["normal"] = vector_json(b.normal);
    box["size"] = {b.long_m, b.short_m};
    box["format"] = b.format;
    boxes.push_back(std::move(box));
  }
  j["boxes"] = std::move(boxes);
  const Plane& p = truth.layer_plane;
  j["layer_plane"] = {p.normal.x(), p.normal.y(), p.normal.z(), p.d};
  j["recipe"] = truth.recipe;
  nlohmann::ordered_json mm = nlohmann::ordered_json::array();
  for (const auto& f : truth.recipe_mm) mm.push_back({f[0], f[1]});
  j["recipe_mm"] = std::move(mm);
  // Only written when it is not the default, so the truth of ordinary frames keeps its bytes.
  if (truth.expect != "boxes") j["expect"] = truth.expect;
  return io_detail::write_file_atomically(stem + kTruthSuffix, j.dump(2) + "\n");
}

}  // namespace palletd
