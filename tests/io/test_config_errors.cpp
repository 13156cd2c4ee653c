// Configuration errors: each kind with file:line:column and the key path.
#include <catch2/catch.hpp>
#include <algorithm>
#include <fstream>

#include "config_failure.hpp"
#include "palletd/config/config.hpp"
#include "png_util.hpp"

using namespace palletd;
using Catch::Contains;
using Catch::StartsWith;

using Failure = test::ConfigFailure;

namespace {

Failure failure_of(const std::string& text) { return test::config_failure_of(text); }

}  // namespace

TEST_CASE("config error: YAML syntax") {
  const Failure f = failure_of("modbus:\n  port: 502\n  allow: [10.0.0.1\n");
  CHECK(f.line >= 3);
  CHECK_THAT(f.what, Contains("bad.yaml:") && Contains("YAML syntax error"));
  const Failure tab = failure_of("modbus:\n  port: 502\n bad_indent: 1\n");
  CHECK(tab.line == 3);
}

TEST_CASE("config error: unknown keys, top level and nested") {
  const Failure top = failure_of("camera:\n  driver: replay\nmodbuss:\n  port: 1\n");
  CHECK(top.line == 3);
  CHECK(top.column == 1);
  CHECK(top.key == "modbuss");
  CHECK_THAT(top.what, StartsWith("bad.yaml:3:1: modbuss: unknown key"));

  const Failure nested = failure_of("modbus:\n  port: 1502\n  prot: 1\n");
  CHECK(nested.line == 3);
  CHECK(nested.column == 3);
  CHECK(nested.key == "modbus.prot");

  const Failure deep = failure_of("detection:\n  plane:\n    max_tilt: 10\n");
  CHECK(deep.line == 3);
  CHECK(deep.column == 5);
  CHECK(deep.key == "detection.plane.max_tilt");
  CHECK_THAT(deep.what, Contains("max_tilt_deg"));  // lists the known keys

  const Failure in_list = failure_of("formats:\n  - {name: A, long_mm: 3, short_mm: 2, weight_kg: 1}\n");
  CHECK(in_list.line == 2);
  CHECK(in_list.key == "formats[0].weight_kg");
}

TEST_CASE("config error: duplicate key") {
  const Failure f = failure_of("modbus:\n  port: 1502\n  port: 1503\n");
  CHECK(f.line == 3);
  CHECK(f.key == "modbus.port");
  CHECK_THAT(f.what, Contains("duplicate key"));
}

TEST_CASE("config error: wrong types") {
  const Failure number = failure_of("modbus:\n  port: five\n");
  CHECK(number.line == 2);
  CHECK(number.column == 9);
  CHECK(number.key == "modbus.port");
  CHECK_THAT(number.what, Contains("bad.yaml:2:9: modbus.port: expected an integer, got 'five'"));

  const Failure fractional = failure_of("modbus:\n  port: 502.5\n");
  CHECK(fractional.key == "modbus.port");
  CHECK_THAT(fractional.what, Contains("expected an integer"));

  const Failure quoted = failure_of("camera:\n  frame_timeout_ms: \"100\"\n");
  CHECK(quoted.line == 2);
  CHECK_THAT(quoted.what, Contains("expected a number, got the string '100'"));

  const Failure flag = failure_of("recording:\n  enabled: maybe\n");
  CHECK(flag.line == 2);
  CHECK(flag.key == "recording.enabled");
  CHECK_THAT(flag.what, Contains("expected true or false"));

  const Failure section = failure_of("logging: 5\n");
  CHECK(section.line == 1);
  CHECK(section.key == "logging");
  CHECK_THAT(section.what, Contains("expected a mapping"));

  const Failure list = failure_of("modbus:\n  allow: 10.0.0.1\n");
  CHECK(list.line == 2);
  CHECK_THAT(list.what, Contains("expected a list"));

  const Failure string = failure_of("camera:\n  driver: [replay]\n");
  CHECK(string.line == 2);
  CHECK_THAT(string.what, Contains("expected a string, got a list"));

  const Failure nothing = failure_of("modbus:\n  port:\n  unit_id: 1\n");
  CHECK(nothing.key == "modbus.port");
  CHECK_THAT(nothing.what, Contains("got nothing"));

  const Failure top = failure_of("- a\n- b\n");
  CHECK(top.line == 1);
  CHECK_THAT(top.what, Contains("top level must be a mapping"));
}

TEST_CASE("config error: out-of-range values") {
  const Failure port = failure_of("\nmodbus:\n  port: 70000\n");
  CHECK(port.line == 3);
  CHECK(port.key == "modbus.port");
  CHECK_THAT(port.what, Contains("between 1 and 65535"));

  const Failure tilt = failure_of("detection:\n  plane: {max_tilt_deg: 95}\n");
  CHECK(tilt.line == 2);
  CHECK(tilt.key == "detection.plane.max_tilt_deg");

  const Failure positive = failure_of("detection:\n  plane:\n    ransac_distance_m: 0\n");
  CHECK(positive.line == 3);
  CHECK_THAT(positive.what, Contains("> 0"));

  const Failure infinite = failure_of("camera:\n  frame_timeout_ms: .inf\n");
  CHECK(infinite.line == 2);
  CHECK_THAT(infinite.what, Contains("finite"));

  const Failure word = failure_of("detection:\n  pick_order: random\n");
  CHECK(word.line == 2);
  CHECK(word.key == "detection.pick_order");
  CHECK_THAT(word.what, Contains("far_corner_first") && Contains("'random'"));

  const Failure driver = failure_of("camera:\n  driver: usb\n");
  CHECK(driver.line == 2);
  CHECK_THAT(driver.what, Contains("replay, aravis, openni2"));

  const Failure reconnect = failure_of("camera:\n  reconnect_min_s: 5\n  reconnect_max_s: 1\n");
  CHECK(reconnect.line == 3);
  CHECK(reconnect.key == "camera.reconnect_max_s");
}

TEST_CASE("config error: addresses") {
  const Failure bind = failure_of("modbus:\n  bind_address: cell-network\n");
  CHECK(bind.line == 2);
  CHECK(bind.key == "modbus.bind_address");
  CHECK_THAT(bind.what, Contains("not an IP address"));

  const Failure prefix = failure_of("modbus:\n  allow:\n    - 10.0.0.0/8\n    - 10.1.0.0/33\n");
  CHECK(prefix.line == 4);
  CHECK(prefix.key == "modbus.allow[1]");
}

TEST_CASE("config: the metrics section, and its errors with line and key") {
  const Config c = parse_config("metrics:\n  enabled: true\n  bind_address: 10.20.1.11\n  port: 9500\n"
                                "  allowed_hosts: [cell7.plant.example]\n", "metrics.yaml");
  CHECK(c.metrics.enabled);
  CHECK(c.metrics.server.bind_address == "10.20.1.11");
  CHECK(c.metrics.server.port == 9500);
  CHECK(c.metrics.server.allowed_hosts == std::vector<std::string>{"cell7.plant.example"});
  CHECK_FALSE(c.metrics.server.status_page);
  CHECK(Config{}.metrics.server.port == 9482);
  CHECK_FALSE(Config{}.metrics.enabled);

  const Failure bind = failure_of("metrics:\n  enabled: true\n  bind_address: monitoring-net\n");
  CHECK(bind.line == 3);
  CHECK(bind.key == "metrics.bind_address");
  const Failure port = failure_of("metrics:\n  port: 70000\n");
  CHECK(port.line == 2);
  CHECK(port.key == "metrics.port");
  const Failure unknown = failure_of("metrics:\n  path: /prom\n");
  CHECK(unknown.line == 2);
  CHECK_THAT(unknown.what, Contains("path"));
}

TEST_CASE("config: the health section reaches the detection's noise model, and its errors have line and key") {
  const Config c = parse_config("health:\n  window_frames: 50\n  max_flying_fraction: 0.4\n"
                                "  noise_model: {sigma_mm_at_1m: 1.5, exponent: 2}\n"
                                "  drift_reference: ref/drift\n  max_drift_deg: 0.5\n",
                                "health.yaml", "/etc/palletd");
  CHECK(c.health.window_frames == 50);
  CHECK(c.health.max_flying_fraction == 0.4);
  CHECK(c.health.max_drift_deg == 0.5);
  CHECK(c.health.max_drift_mm == 10.0);  // default kept
  CHECK(c.health.drift_reference == "/etc/palletd/ref/drift");
  CHECK(c.detection.noise_model.sigma_mm_at_1m == 1.5);
  CHECK(c.detection.noise_model.exponent == 2.0);
  CHECK_FALSE(Config{}.detection.noise_model.enabled());

  const Failure share = failure_of("health:\n  max_invalid_fraction: 1.5\n");
  CHECK(share.line == 2);
  CHECK(share.key == "health.max_invalid_fraction");
  const Failure nested = failure_of("health:\n  noise_model:\n    sigma_mm_at_1m: -1\n");
  CHECK(nested.line == 3);
  CHECK(nested.key == "health.noise_model.sigma_mm_at_1m");
  const Failure window = failure_of("health:\n  window_frames: 0\n");
  CHECK(window.key == "health.window_frames");
}

TEST_CASE("config: shadow_config loads a second file, and its errors name that file") {
  const std::string dir = std::string(PALLETD_BINARY_DIR) + "/tests/io";
  const auto write = [](const std::string& path, const std::string& text) {
    std::ofstream(path) << text;
  };
  write(dir + "/shadow_ok.yaml", "formats:\n  - {name: a, long_mm: 400, short_mm: 300}\n"
                                 "recipes:\n  - {number: 1, name: a, formats: [a]}\n");
  const Config c = parse_config("shadow_config: shadow_ok.yaml\n", "live.yaml", dir);
  CHECK(c.shadow_config == dir + "/shadow_ok.yaml");
  REQUIRE(c.shadow);
  CHECK(c.shadow->recipes.size() == 1);
  CHECK_FALSE(parse_config("shadow_config: null\n", "live.yaml", dir).shadow);

  write(dir + "/shadow_bad.yaml", "formats:\n  - {name: a, long_mm: 400, short_mm: -3}\n");
  try {
    (void)parse_config("shadow_config: shadow_bad.yaml\n", "live.yaml", dir);
    FAIL("no error for a bad shadow configuration");
  } catch (const ConfigError& e) {
    CHECK_THAT(std::string(e.what()), Contains("shadow_bad.yaml:2"));
  }
  write(dir + "/shadow_nested.yaml", "shadow_config: shadow_ok.yaml\n");
  const Failure nested = failure_of("\nshadow_config: " + dir + "/shadow_nested.yaml\n");
  CHECK(nested.line == 2);
  CHECK(nested.key == "shadow_config");
  CHECK_THAT(nested.what, Contains("shadow configuration of its own"));
  const Failure missing = failure_of("shadow_config: " + dir + "/no_such_shadow.yaml\n");
  CHECK_THAT(missing.what, Contains("no_such_shadow.yaml"));
  const Failure device = failure_of("shadow_config: /dev/zero\n");  // would never end
  CHECK_THAT(device.what, Contains("/dev/zero") && Contains("not a regular file"));
}

TEST_CASE("config error: box formats") {
  const Failure missing = failure_of("formats:\n  - {name: A, long_mm: 300}\n");
  CHECK(missing.line == 2);
  CHECK(missing.key == "formats[0]");
  CHECK_THAT(missing.what, Contains("missing key 'short_mm'"));

  const Failure swapped = failure_of("formats:\n  - name: A\n    long_mm: 200\n    short_mm: 300\n");
  CHECK(swapped.line == 4);
  CHECK(swapped.key == "formats[0].short_mm");
  CHECK_THAT(swapped.what, Contains("long side first"));

  const Failure zero = failure_of("formats:\n  - {name: A, long_mm: 300, short_mm: 0}\n");
  CHECK(zero.key == "formats[0].short_mm");

  const Failure dup = failure_of("formats:\n  - {name: A, long_mm: 3, short_mm: 2}\n  - {name: A, long_mm: 4, short_mm: 2}\n");
  CHECK(dup.line == 3);
  CHECK(dup.key == "formats[1].name");
  CHECK_THAT(dup.what, Contains("already defined by formats[0]"));
}

TEST_CASE("config error: recipes") {
  const std::string formats = "formats:\n  - {name: A, long_mm: 300, short_mm: 200}\n";
  const Failure unknown = failure_of(formats + "recipes:\n  - {number: 1, formats: [A, B]}\n");
  CHECK(unknown.line == 4);
  CHECK(unknown.key == "recipes[0].formats[1]");
  CHECK_THAT(unknown.what, Contains("unknown format 'B'"));

  const Failure dup = failure_of(formats + "recipes:\n  - {number: 1, formats: [A]}\n  - {number: 1, formats: [A]}\n");
  CHECK(dup.line == 5);
  CHECK(dup.key == "recipes[1].number");

  const Failure empty = failure_of(formats + "recipes:\n  - {number: 2, formats: []}\n");
  CHECK(empty.line == 4);
  CHECK_THAT(empty.what, Contains("at least one format"));

  const Failure number = failure_of(formats + "recipes:\n  - {number: 0, formats: [A]}\n");
  CHECK(number.key == "recipes[0].number");

  const Failure default_recipe =
      failure_of(formats + "recipes:\n  - {number: 2, formats: [A]}\npipeline:\n  default_recipe: 3\n");
  CHECK(default_recipe.line == 6);
  CHECK(default_recipe.key == "pipeline.default_recipe");
}

TEST_CASE("config: a size-range recipe, and its errors with line and key") {
  const Config ok = parse_config(
      "recipes:\n  - {number: 90, name: unknown, size_range_mm: {long: [200, 800], short: [150, 600]}}\n"
      "pipeline:\n  default_recipe: 90\n",
      "r.yaml");
  REQUIRE(ok.recipes.size() == 1);
  REQUIRE(ok.recipes[0].size_range.has_value());
  CHECK(ok.recipes[0].formats.empty());
  CHECK(ok.recipes[0].size_range->long_min_m == Approx(0.2));
  CHECK(ok.recipes[0].size_range->short_max_m == Approx(0.6));
  CHECK(recipe_candidates(ok, 0).empty());  // a size range fits any carton: it is never named as best

  const std::string formats = "formats:\n  - {name: A, long_mm: 300, short_mm: 200}\n";
  const Failure both =
      failure_of(formats + "recipes:\n  - {number: 1, formats: [A], size_range_mm: {long: [1, 2], short: [1, 2]}}\n");
  CHECK(both.line == 4);
  CHECK_THAT(both.what, Contains("formats or a size range, not both"));
  const Failure reversed =
      failure_of("recipes:\n  - number: 1\n    size_range_mm:\n      long: [800, 200]\n      short: [150, 600]\n");
  CHECK(reversed.line == 4);
  CHECK(reversed.key == "recipes[0].size_range_mm.long");
  const Failure missing = failure_of("recipes:\n  - {number: 1, size_range_mm: {long: [200, 800]}}\n");
  CHECK_THAT(missing.what, Contains("short"));
}

TEST_CASE("config error: camera_to_base and intrinsics") {
  const Failure length = failure_of("camera_to_base: [1, 0, 0, 0]\n");
  CHECK(length.line == 1);
  CHECK(length.key == "camera_to_base");
  CHECK_THAT(length.what, Contains("16 numbers"));

  const Failure rigid = failure_of("camera_to_base: [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 2, 0,  0, 0, 0, 1]\n");
  CHECK_THAT(rigid.what, Contains("not a rigid transform"));

  const Failure mirrored = failure_of("\ncamera_to_base: [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, -1, 0,  0, 0, 0, 1]\n");
  CHECK(mirrored.line == 2);
  CHECK_THAT(mirrored.what, Contains("determinant +1"));

  const Failure entry = failure_of("camera_to_base: [1, 0, 0, 0,  0, 1, 0, x,  0, 0, 1, 0,  0, 0, 0, 1]\n");
  CHECK(entry.key == "camera_to_base[7]");
  CHECK(entry.column == 40);

  const Failure fx = failure_of("camera:\n  intrinsics:\n    {width: 64, height: 48, fx: 0, fy: 50, cx: 32, cy: 24}\n");
  CHECK(fx.line == 3);
  CHECK(fx.key == "camera.intrinsics.fx");
  CHECK_THAT(fx.what, Contains("focal length"));

  const Failure cy = failure_of("camera:\n  intrinsics: {width: 64, height: 48, fx: 50, fy: 50, cx: 32}\n");
  CHECK(cy.key == "camera.intrinsics");
  CHECK_THAT(cy.what, Contains("missing key 'cy'"));
}

TEST_CASE("config error: a missing file names the file") {
  palletd::test::TempDir dir;
  try {
    (void)load_config(dir.file("missing.yaml"));
    FAIL("no error");
  } catch (const ConfigError& e) {
    CHECK(e.file() == dir.file("missing.yaml"));
    CHECK(e.line() == 0);
    CHECK_THAT(e.what(), Contains("missing.yaml") && Contains("not found"));
  }
  palletd::test::write_text_file(dir.file("bad.yaml"), "logging:\n  level: loud\n");
  try {
    (void)load_config(dir.file("bad.yaml"));
    FAIL("no error");
  } catch (const ConfigError& e) {
    CHECK(e.file() == dir.file("bad.yaml"));
    CHECK(e.line() == 2);
    CHECK(e.column() == 10);
    CHECK_THAT(e.what(), Contains(dir.file("bad.yaml") + ":2:10: logging.level: must be one of"));
  }
}

TEST_CASE("config: detection.roi in the base frame, with camera_to_base") {
  const Config c = parse_config(R"(camera_to_base: [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]
detection:
  roi:
    frame: base
    min_m: [-0.8, -0.6, 0.1]
    max_m: [0.8, 0.6, 2.2]
)",
                                "roi.yaml");
  REQUIRE(c.detection.roi.has_value());
  CHECK(c.detection.roi->frame == RegionOfInterest::Frame::kBase);
  CHECK(c.detection.roi->min_m.isApprox(Eigen::Vector3d(-0.8, -0.6, 0.1)));
  CHECK(c.detection.roi->max_m.isApprox(Eigen::Vector3d(0.8, 0.6, 2.2)));
  CHECK_FALSE(parse_config("detection: {roi: null}\n", "none.yaml").detection.roi.has_value());
}

TEST_CASE("config error: detection.roi (base frame without camera_to_base, min >= max, lengths, frame word)") {
  const Failure base = failure_of("detection:\n  roi:\n    frame: base\n    min_m: [0, 0, 0]\n    max_m: [1, 1, 1]\n");
  CHECK(base.line == 3);
  CHECK(base.key == "detection.roi.frame");
  CHECK_THAT(base.what, Contains("camera_to_base"));
  const Failure order =
      failure_of("detection:\n  roi:\n    frame: camera\n    min_m: [0, 0, 2]\n    max_m: [1, 1, 1]\n");
  CHECK(order.line == 5);
  CHECK(order.key == "detection.roi.max_m");
  CHECK_THAT(order.what, Contains("z: "));
  const Failure length = failure_of("detection:\n  roi:\n    frame: camera\n    min_m: [0, 0]\n    max_m: [1, 1, 1]\n");
  CHECK(length.line == 4);
  CHECK(length.key == "detection.roi.min_m");
  const Failure word = failure_of("detection:\n  roi:\n    frame: world\n    min_m: [0, 0, 0]\n    max_m: [1, 1, 1]\n");
  CHECK(word.key == "detection.roi.frame");
  CHECK_THAT(word.what, Contains("base or camera"));
  const Failure missing = failure_of("detection:\n  roi: {frame: camera, min_m: [0, 0, 0]}\n");
  CHECK_THAT(missing.what, Contains("max_m"));
}

TEST_CASE(
    "config: offline tools take a base-frame region and pallet height whose calibration comes with the "
    "frames") {
  const std::string text =
      "detection:\n  roi: {frame: base, min_m: [0, 0, 0], max_m: [1, 1, 1]}\npallet: {top_z_m: 0.14}\n";
  CHECK_THROWS_AS(parse_config(text, "cell.yaml"), ConfigError);  // the daemon: no calibration, no region
  const Config c = parse_config(text, "cell.yaml", "", CalibrationSource::kConfigurationOrFrames);
  REQUIRE(c.detection.roi.has_value());
  CHECK(c.detection.roi->frame == RegionOfInterest::Frame::kBase);
  CHECK_FALSE(c.T_base_camera.has_value());
  REQUIRE(c.detection.pallet.top_z_m.has_value());
  CHECK(*c.detection.pallet.top_z_m == Approx(0.14));
}

TEST_CASE("config: pallet.top_z_m and formats' height_mm") {
  const Config c = parse_config(R"(camera_to_base: [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]
formats:
  - {name: F600, long_mm: 600, short_mm: 400, height_mm: 220}
  - {name: F315, long_mm: 315, short_mm: 232}
pallet:
  top_z_m: 0.144
)",
                                "pallet.yaml");
  REQUIRE(c.detection.pallet.top_z_m.has_value());
  CHECK(*c.detection.pallet.top_z_m == Approx(0.144));
  CHECK(c.formats[0].height_m == Approx(0.22));
  CHECK(c.formats[1].height_m == 0.0);
  CHECK_FALSE(parse_config("pallet: {top_z_m: null}\n", "none.yaml").detection.pallet.top_z_m.has_value());
  const Config other = parse_config(R"(camera_to_base: [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 0, 1]
formats:
  - {name: F600, long_mm: 600, short_mm: 400, height_mm: 200}
  - {name: F315, long_mm: 315, short_mm: 232}
pallet:
  top_z_m: 0.15
)",
                                    "other.yaml");
  const std::vector<std::string> diffs = config_differences(c, other);
  CHECK(std::find(diffs.begin(), diffs.end(), "formats") != diffs.end());
  CHECK(std::find(diffs.begin(), diffs.end(), "pallet.top_z_m") != diffs.end());
}

TEST_CASE("config error: pallet.top_z_m without camera_to_base, height_mm out of range") {
  const Failure uncalibrated = failure_of("pallet:\n  top_z_m: 0.144\n");
  CHECK(uncalibrated.line == 2);
  CHECK(uncalibrated.key == "pallet.top_z_m");
  CHECK_THAT(uncalibrated.what, Contains("camera_to_base"));
  const Failure word = failure_of("pallet:\n  top_z_m: high\n");
  CHECK(word.key == "pallet.top_z_m");
  const Failure height = failure_of("formats:\n  - {name: A, long_mm: 600, short_mm: 400, height_mm: 0}\n");
  CHECK(height.line == 2);
  CHECK(height.key == "formats[0].height_mm");
  const Failure tolerance = failure_of("pallet:\n  height_tolerance: 0.9\n");
  CHECK(tolerance.key == "pallet.height_tolerance");
}
