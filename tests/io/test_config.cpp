// Configuration: defaults, the documented file, the demo file, relative paths.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>

#include <yaml-cpp/yaml.h>

#include "palletd/config/config.hpp"
#include "png_util.hpp"

using namespace palletd;

namespace {

const std::string kSourceDir = PALLETD_SOURCE_DIR;

/// True when `path` ("a.b.c") names a key present in the YAML document.
bool has_key(const YAML::Node& root, const std::string& path) {
  YAML::Node node = YAML::Clone(root);
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node.IsMap() || !node[key]) return false;
    const YAML::Node child = node[key];
    node.reset(child);  // re-point without assigning (assignment would overwrite the document)
    if (dot == std::string::npos) return true;
    start = dot + 1;
  }
}

}  // namespace

TEST_CASE("an empty configuration gives the defaults") {
  const Config empty = parse_config("", "empty.yaml");
  CHECK(config_differences(empty, Config{}).empty());
  CHECK(empty.source_path == "empty.yaml");
  CHECK(empty.camera.driver == "replay");
  CHECK(empty.modbus.bind_address == "127.0.0.1");
  CHECK(empty.modbus.port == 502);
  CHECK_FALSE(empty.T_base_camera.has_value());
  CHECK(empty.formats.empty());
  CHECK(empty.recipes.empty());
  CHECK(empty.detection.pick_order == PickOrder::kFarCornerFirst);
  const Config comments = parse_config("# nothing but a comment\n", "c.yaml");
  CHECK(config_differences(comments, Config{}).empty());
  const Config empty_sections = parse_config("camera:\nmodbus:\ndetection:\n", "s.yaml");
  CHECK(config_differences(empty_sections, Config{}).empty());
}

TEST_CASE("config_differences names the keys that differ") {
  const Config changed = parse_config(
      "modbus: {port: 1502, allow: [10.0.0.0/8]}\ndetection: {plane: {max_tilt_deg: 20}, pick_order: row_major}\n"
      "camera: {replay: {loop: false}}\n",
      "x.yaml");
  auto diffs = config_differences(changed, Config{});
  std::sort(diffs.begin(), diffs.end());
  const std::vector<std::string> expected = {"camera.replay.loop", "detection.pick_order",
                                             "detection.plane.max_tilt_deg", "modbus.allow", "modbus.port"};
  CHECK(diffs == expected);
  CHECK(changed.modbus.port == 1502);
  CHECK(changed.detection.plane.max_tilt_deg == 20.0);
  CHECK(changed.detection.pick_order == PickOrder::kRowMajor);
}

TEST_CASE("config/palletd.yaml parses and equals the defaults") {
  const std::string path = kSourceDir + "/config/palletd.yaml";
  const Config config = load_config(path);
  const auto diffs = config_differences(config, Config{});
  std::string listed;
  for (const auto& d : diffs) listed += d + " ";
  INFO("keys whose documented value differs from the default: " << listed);
  CHECK(diffs.empty());
  CHECK(config.source_path == path);
}

TEST_CASE("config/palletd.yaml documents every key") {
  const YAML::Node root = YAML::LoadFile(kSourceDir + "/config/palletd.yaml");
  const auto keys = config_key_paths();
  CHECK(keys.size() > 40);
  for (const std::string& key : keys) {
    INFO(key);
    CHECK(has_key(root, key));
  }
  CHECK_FALSE(has_key(root, "modbus.no_such_key"));
}

TEST_CASE("config/demo.yaml defines the bundled formats and recipes") {
  const Config demo = load_config(kSourceDir + "/config/demo.yaml");
  CHECK(demo.camera.driver == "replay");
  // Relative to the config file's folder, not to the working directory.
  CHECK(std::filesystem::path(demo.camera.replay.directory) ==
        (std::filesystem::path(kSourceDir) / "tests/data").lexically_normal());
  REQUIRE(demo.formats.size() == 5);
  CHECK(demo.formats[3].name == "315x232");
  CHECK(demo.formats[3].long_m == Approx(0.315));
  CHECK(demo.formats[3].short_m == Approx(0.232));
  REQUIRE(demo.recipes.size() == 7);
  for (int i = 0; i < 5; ++i) {
    CHECK(demo.recipes[static_cast<std::size_t>(i)].number == i + 1);
    CHECK(demo.recipes[static_cast<std::size_t>(i)].formats == std::vector<int>{i});
  }
  CHECK(demo.recipes[5].formats == std::vector<int>{0, 1, 2, 3, 4});
  CHECK(demo.recipes[6].formats == std::vector<int>{0, 1, 2});  // the mixed bundled frame's recipe
  CHECK(demo.web.enabled);
  CHECK(demo.pipeline.default_recipe == 6);
}

TEST_CASE("every section parses into its struct") {
  const std::string text = R"(
camera:
  driver: aravis
  intrinsics: {width: 640, height: 480, fx: 500.5, fy: 501, cx: 319.5, cy: 239.5,
               distortion: [0.1, -0.2, 0.001, 0.002, 0.05]}
  aravis: {address: 192.168.10.50, pixel_format: Mono16, mono16_scale_m: 0.0002, packet_size: 8192}
  openni2: {uri: /tmp/x.oni, fps: 15}
camera_to_base: [0, -1, 0, 0.5,  1, 0, 0, -0.25,  0, 0, 1, 2.0,  0, 0, 0, 1]
formats:
  - {name: A, long_mm: 600, short_mm: 400}
  - {name: B, long_mm: 300, short_mm: 300}
recipes:
  - {number: 7, name: both, formats: [B, A]}
detection:
  layer: {passthrough_tolerance_m: 0.015}
  contour: {d_max_m: 0.02}
  layout: {search: paper, time_budget_ms: 120}
modbus: {bind_address: "::1", unit_id: 0, low_word_first: yes, read_only: [192.168.1.7, "fe80::/10"]}
pipeline: {detection_timeout_ms: 500, default_recipe: 7}
logging: {level: debug}
recording: {enabled: true, directory: rec, max_bytes: 1048576, every_trigger: true, overlays: false}
)";
  const Config c = parse_config(text, "all.yaml", "/etc/palletd");
  CHECK(c.camera.driver == "aravis");
  REQUIRE(c.camera.intrinsics_override.has_value());
  CHECK(c.camera.intrinsics_override->fx == 500.5);
  CHECK(c.camera.intrinsics_override->fy == 501.0);
  REQUIRE(c.camera.intrinsics_override->distortion.has_value());
  CHECK((*c.camera.intrinsics_override->distortion)[4] == 0.05);
  CHECK(c.camera.aravis.address == "192.168.10.50");
  CHECK(c.camera.aravis.pixel_format == "Mono16");
  CHECK(c.camera.aravis.mono16_scale_m == 0.0002);
  CHECK(c.camera.aravis.packet_size == 8192);
  CHECK(c.camera.openni2.fps == 15);
  CHECK(c.camera.openni2.uri == "/tmp/x.oni");  // absolute paths are kept
  REQUIRE(c.T_base_camera.has_value());
  CHECK(c.T_base_camera->translation() == Eigen::Vector3d(0.5, -0.25, 2.0));
  CHECK((*c.T_base_camera * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d(0.5, 0.75, 2.0)));
  REQUIRE(c.formats.size() == 2);
  CHECK(c.formats[1].short_m == 0.3);
  REQUIRE(c.recipes.size() == 1);
  CHECK(c.recipes[0].number == 7);
  CHECK(c.recipes[0].name == "both");
  CHECK(c.recipes[0].formats == std::vector<int>{1, 0});
  CHECK(c.detection.layer.passthrough_tolerance_m == 0.015);
  CHECK(c.detection.contour.d_max_m == 0.02);
  CHECK(c.detection.layout.search.mode == SearchMode::kPaper);
  CHECK(c.detection.layout.search.time_budget_ms == 120.0);
  CHECK(c.modbus.bind_address == "::1");
  CHECK(c.modbus.unit_id == 0);
  CHECK(c.modbus.handshake.word_order == modbus::WordOrder::kLowWordFirst);
  CHECK(c.modbus.read_only == std::vector<std::string>{"192.168.1.7", "fe80::/10"});
  CHECK(c.pipeline.detection_timeout_ms == 500.0);
  CHECK(c.logging.level == "debug");
  CHECK(c.recording.enabled);
  CHECK(c.recording.directory == "/etc/palletd/rec");
  CHECK(c.recording.max_bytes == 1048576u);
  CHECK(c.recording.every_trigger);
  CHECK_FALSE(c.recording.overlays);
}

TEST_CASE("relative paths stay as written without a base folder") {
  const Config c = parse_config("camera: {replay: {directory: frames}}\n", "text");
  CHECK(c.camera.replay.directory == "frames");
  palletd::test::TempDir dir;
  palletd::test::write_text_file(dir.file("p.yaml"), "camera: {replay: {directory: frames/a}}\n");
  const Config loaded = load_config(dir.file("p.yaml"));
  CHECK(loaded.camera.replay.directory == dir.file("frames/a"));
}
