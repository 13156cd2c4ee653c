// The configuration file: YAML in, plain structs out, every error with file:line:column and key path.
#include "palletd/config/config.hpp"

#include <cmath>
#include <filesystem>
#include <set>

#include "config_yaml.hpp"
#include "palletd/frames/files.hpp"

namespace palletd {


using namespace config_detail;

namespace {

const std::vector<std::string>& top_level_keys() {
  static const std::vector<std::string> keys = {"camera",    "camera_to_base", "formats",
                                                "recipes",   "pallet",         "detection",      "modbus",
                                                "pipeline",  "logging",        "recording", "web", "metrics",
                                                "health",    "gripper",        "check",          "shadow_config"};
  return keys;
}

YAML::Node load_yaml(const std::string& name, const std::string& text) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    fail_at(Context{name, ""}, e.mark, "", "YAML syntax error: " + e.msg);
  }
}

/// `shadow_config: FILE` (null = none): loads FILE as a configuration of its own (its errors name
/// FILE and its line); a shadow may not name a shadow of its own.
void read_shadow_config(const Context& ctx, const YAML::Node& node, Config& config) {
  if (node.IsNull()) return;
  config.shadow_config = resolve_path(ctx, read_string(ctx, node, "shadow_config"));
  if (config.shadow_config.empty()) return;
  Config shadow = load_config(config.shadow_config);
  if (!shadow.shadow_config.empty())
    fail(ctx, node, "shadow_config", config.shadow_config + " names a shadow configuration of its own");
  config.shadow = std::make_shared<const Config>(std::move(shadow));
}

void parse_into(const Context& ctx, const YAML::Node& root, CalibrationSource calibration, Config& config) {
  if (root.IsNull()) return;
  if (!root.IsMap()) fail(ctx, root, "", "the top level must be a mapping of sections, got " + describe(root));
  check_keys(ctx, root, "", top_level_keys());
  if (const YAML::Node n = root["camera"]) read_section(ctx, n, "camera", camera_table(), config.camera);
  if (const YAML::Node n = root["camera_to_base"]) config.T_base_camera = read_camera_to_base(ctx, n, "camera_to_base");
  if (const YAML::Node n = root["formats"]) config.formats = read_formats(ctx, n, "formats");
  if (const YAML::Node n = root["recipes"]) config.recipes = read_recipes(ctx, n, "recipes", config.formats);
  if (const YAML::Node n = root["detection"]) read_section(ctx, n, "detection", detection_table(), config.detection);
  if (const YAML::Node n = root["pallet"]) read_section(ctx, n, "pallet", pallet_table(), config.detection.pallet);
  if (const YAML::Node n = root["modbus"]) read_section(ctx, n, "modbus", modbus::server_table(), config.modbus);
  if (const YAML::Node n = root["pipeline"]) read_section(ctx, n, "pipeline", pipeline_table(), config.pipeline);
  if (const YAML::Node n = root["logging"]) read_section(ctx, n, "logging", logging_table(), config.logging);
  if (const YAML::Node n = root["recording"]) read_section(ctx, n, "recording", recording_table(), config.recording);
  if (const YAML::Node n = root["web"]) read_section(ctx, n, "web", web_table(), config.web);
  if (const YAML::Node n = root["metrics"]) read_section(ctx, n, "metrics", metrics_table(), config.metrics);
  if (const YAML::Node n = root["health"]) read_section(ctx, n, "health", health_table(), config.health);
  if (const YAML::Node n = root["gripper"]) config.detection.gripper = read_gripper(ctx, n, "gripper");
  if (const YAML::Node n = root["check"]) read_section(ctx, n, "check", check_table(), config.check);
  config.detection.noise_model = config.health.noise_model;  // detect() measures against it
  if (const YAML::Node n = root["shadow_config"]) read_shadow_config(ctx, n, config);

  // Checks across keys, reported at the later key.
  const bool calibrated = config.T_base_camera || calibration == CalibrationSource::kConfigurationOrFrames;
  if (config.detection.roi && config.detection.roi->frame == RegionOfInterest::Frame::kBase && !calibrated) {
    fail(ctx, root["detection"]["roi"]["frame"], "detection.roi.frame",
         "a region in the base frame needs camera_to_base (or use frame: camera)");
  }
  if (config.detection.pallet.top_z_m && !calibrated) {
    fail(ctx, root["pallet"]["top_z_m"], "pallet.top_z_m", "a height in the base frame needs camera_to_base");
  }
  if (config.camera.reconnect_max_s < config.camera.reconnect_min_s) {
    const YAML::Node camera = root["camera"];
    const YAML::Node at = camera["reconnect_max_s"] ? camera["reconnect_max_s"] : camera["reconnect_min_s"];
    fail(ctx, at, "camera.reconnect_max_s", "must not be below camera.reconnect_min_s");
  }
  if (!config.recipes.empty()) {
    const int wanted = config.pipeline.default_recipe;
    const bool known = std::any_of(config.recipes.begin(), config.recipes.end(),
                                   [&](const Recipe& r) { return r.number == wanted; });
    if (!known) {
      const YAML::Node pipeline = root["pipeline"];
      const YAML::Node at = pipeline && pipeline.IsMap() && pipeline["default_recipe"] ? pipeline["default_recipe"]
                                                                                       : root["recipes"];
      fail(ctx, at, "pipeline.default_recipe",
           "recipe " + std::to_string(wanted) + " is not defined under recipes");
    }
  }
}

}  // namespace

Config parse_config(const std::string& yaml_text, const std::string& name, const std::string& base_directory,
                    CalibrationSource calibration) {
  const Context ctx{name, base_directory};
  const YAML::Node root = load_yaml(name, yaml_text);
  Config config;
  config.source_path = name;
  try {
    parse_into(ctx, root, calibration, config);
  } catch (const YAML::Exception& e) {  // not expected; still reported as a config error
    fail_at(ctx, e.mark, "", e.msg);
  }
  return config;
}

Config load_config(const std::string& path, CalibrationSource calibration) {
  // A configuration is a regular file of a sane size: a device (/dev/zero) or a huge file named
  // by mistake (or by shadow_config) must fail, not hang the start.
  constexpr std::uintmax_t kMaxBytes = 1u << 20;
  std::error_code exists_ec;
  if (std::filesystem::exists(path, exists_ec)) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec) && !std::filesystem::is_directory(path, ec))
      throw ConfigError(path, 0, 0, "", "cannot read the configuration: not a regular file");
    if (std::filesystem::is_regular_file(path, ec) && std::filesystem::file_size(path, ec) > kMaxBytes)
      throw ConfigError(path, 0, 0, "", "cannot read the configuration: larger than 1 MiB");
  }
  auto text = io_detail::read_text_file(path);
  if (!text) throw ConfigError(path, 0, 0, "", "cannot read the configuration: " + text.error());
  std::error_code ec;
  const std::filesystem::path absolute = std::filesystem::absolute(path, ec);
  const std::string base = ec ? std::string() : absolute.parent_path().lexically_normal().string();
  return parse_config(*text, path, base, calibration);
}

CellFile load_cell_file(const std::string& path) {
  auto text = io_detail::read_text_file(path);
  if (!text) throw ConfigError(path, 0, 0, "", "cannot read the cell file: " + text.error());
  const Context ctx{path, ""};
  const YAML::Node root = load_yaml(path, *text);
  CellFile cell;
  if (root.IsNull()) return cell;
  if (!root.IsMap()) fail(ctx, root, "", "expected a mapping with detection.roi and pallet, got " + describe(root));
  check_keys(ctx, root, "", {"detection", "pallet"});
  if (const YAML::Node detection = root["detection"]) {
    if (!detection.IsMap()) fail(ctx, detection, "detection", "expected a mapping holding roi, got " + describe(detection));
    check_keys(ctx, detection, "detection", {"roi"});
    if (const YAML::Node roi = detection["roi"]) cell.roi = read_roi(ctx, roi, "detection.roi");
  }
  if (const YAML::Node n = root["pallet"]) read_section(ctx, n, "pallet", pallet_table(), cell.pallet);
  return cell;
}

std::vector<std::string> config_differences(const Config& a, const Config& b) {
  std::vector<std::string> diffs;
  compare_section(a.camera, b.camera, "camera", camera_table(), diffs);
  if (a.T_base_camera.has_value() != b.T_base_camera.has_value() ||
      (a.T_base_camera && a.T_base_camera->matrix() != b.T_base_camera->matrix()))
    diffs.emplace_back("camera_to_base");
  const auto same_format = [](const BoxFormat& x, const BoxFormat& y) {
    return x.name == y.name && x.long_m == y.long_m && x.short_m == y.short_m && x.height_m == y.height_m;
  };
  if (!std::equal(a.formats.begin(), a.formats.end(), b.formats.begin(), b.formats.end(), same_format))
    diffs.emplace_back("formats");
  const auto same_recipe = [](const Recipe& x, const Recipe& y) {
    const auto same_range = [](const std::optional<SizeRange>& p, const std::optional<SizeRange>& q) {
      return p.has_value() == q.has_value() &&
             (!p || (p->long_min_m == q->long_min_m && p->long_max_m == q->long_max_m &&
                     p->short_min_m == q->short_min_m && p->short_max_m == q->short_max_m));
    };
    return x.number == y.number && x.name == y.name && x.formats == y.formats && same_range(x.size_range, y.size_range);
  };
  if (!std::equal(a.recipes.begin(), a.recipes.end(), b.recipes.begin(), b.recipes.end(), same_recipe))
    diffs.emplace_back("recipes");
  compare_section(a.detection, b.detection, "detection", detection_table(), diffs);
  compare_section(a.detection.pallet, b.detection.pallet, "pallet", pallet_table(), diffs);
  compare_section(a.modbus, b.modbus, "modbus", modbus::server_table(), diffs);
  compare_section(a.pipeline, b.pipeline, "pipeline", pipeline_table(), diffs);
  compare_section(a.logging, b.logging, "logging", logging_table(), diffs);
  compare_section(a.recording, b.recording, "recording", recording_table(), diffs);
  compare_section(a.web, b.web, "web", web_table(), diffs);
  compare_section(a.metrics, b.metrics, "metrics", metrics_table(), diffs);
  compare_section(a.health, b.health, "health", health_table(), diffs);
  if (!(a.detection.gripper == b.detection.gripper)) diffs.emplace_back("gripper");
  compare_section(a.check, b.check, "check", check_table(), diffs);
  if (a.shadow_config != b.shadow_config) diffs.emplace_back("shadow_config");
  return diffs;
}

std::vector<std::string> config_key_paths() {
  std::vector<std::string> keys;
  list_section("camera", camera_table(), keys);
  keys.emplace_back("camera_to_base");
  keys.emplace_back("formats");
  keys.emplace_back("recipes");
  list_section("pallet", pallet_table(), keys);
  list_section("detection", detection_table(), keys);
  list_section("modbus", modbus::server_table(), keys);
  list_section("pipeline", pipeline_table(), keys);
  list_section("logging", logging_table(), keys);
  list_section("recording", recording_table(), keys);
  list_section("web", web_table(), keys);
  list_section("metrics", metrics_table(), keys);
  list_section("health", health_table(), keys);
  keys.emplace_back("gripper");
  list_section("check", check_table(), keys);
  keys.emplace_back("shadow_config");
  return keys;
}

std::vector<RecipeCandidate> recipe_candidates(const Config& config, int except) {
  std::vector<RecipeCandidate> out;
  for (const Recipe& r : config.recipes) {
    if (r.number == except || r.size_range) continue;  // a size range fits any carton: it names none
    RecipeCandidate c{r.number, {}};
    for (int index : r.formats) c.formats.push_back(config.formats[static_cast<std::size_t>(index)]);
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace palletd
