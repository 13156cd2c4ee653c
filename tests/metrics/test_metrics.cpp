// Metrics: the counters, histograms and gauges palletd exposes, rendered by prometheus-cpp and
// read back from the text; the text checked by Prometheus's own promtool.
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "palletd/metrics/metrics.hpp"

using namespace palletd;

namespace {

/// Sample lines of the exposition text: "name{labels}" -> value.
std::map<std::string, double> samples(const std::string& text) {
  std::map<std::string, double> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const auto space = line.rfind(' ');
    REQUIRE(space != std::string::npos);
    out[line.substr(0, space)] = std::stod(line.substr(space + 1));
  }
  return out;
}

ResultSnapshot result(DetectionStatus status, std::size_t boxes, double total_ms) {
  ResultSnapshot r;
  r.detection.status = status;
  r.detection.boxes.resize(boxes);
  r.detection.timing_ms = {{"total", total_ms}, {"plane", total_ms / 4}, {"layout", total_ms / 2}};
  r.frame = std::make_shared<const Frame>();
  r.latency_ms = total_ms + 30.0;
  return r;
}

struct Fixture {
  ServiceHealth health;
  modbus::ServerStats modbus;
  std::string hash = "0123abcd";
  Metrics metrics{
      MetricsSource{[this] { return health; }, [this] { return modbus; }, [this] { return hash; }},
      BuildInfo{"1.2.3", "abcdef012345"}};
};

}  // namespace

TEST_CASE("results are counted by status and reason, ambiguous ones by reason", "[metrics]") {
  Fixture f;
  ResultSnapshot ok = result(DetectionStatus::kOk, 12, 20.0);
  ok.detection.ambiguous = true;
  ok.detection.ambiguity_kinds = {AmbiguityKind::kTiedLayouts, AmbiguityKind::kHeightOffLayers};
  ok.detection.height_above_pallet_m = 1.25;
  ok.detection.layers_remaining = 5;
  f.metrics.observe(ok);
  f.metrics.observe(result(DetectionStatus::kOk, 12, 30.0));
  f.metrics.observe(result(DetectionStatus::kEmpty, 0, 10.0));
  f.metrics.observe(result(DetectionStatus::kSlipSheet, 0, 10.0));
  f.metrics.observe(result(DetectionStatus::kNoPlane, 0, 5.0));
  ResultSnapshot timeout;  // no frame came: no detection ran
  timeout.error = modbus::ErrorCode::kFrameTimeout;
  timeout.error_text = "frame: no frame captured";
  timeout.latency_ms = 2000.0;
  f.metrics.observe(timeout);

  const auto s = samples(f.metrics.render());
  CHECK(s.at("palletd_results_total{status=\"ok\"}") == 2);
  CHECK(s.at("palletd_results_total{status=\"empty\"}") == 1);
  CHECK(s.at("palletd_results_total{status=\"slip_sheet\"}") == 1);
  CHECK(s.at("palletd_results_total{reason=\"no_plane\",status=\"failed\"}") == 1);
  CHECK(s.at("palletd_results_total{reason=\"frame_timeout\",status=\"failed\"}") == 1);
  CHECK(s.at("palletd_ambiguous_results_total{reason=\"tied_layouts\"}") == 1);
  CHECK(s.at("palletd_ambiguous_results_total{reason=\"height_off_layers\"}") == 1);
  CHECK(s.count("palletd_ambiguous_results_total{reason=\"search_budget\"}") == 0);
  // Five detections ran (the timeout had no frame); six latencies.
  CHECK(s.at("palletd_detection_seconds_count") == 5);
  CHECK(s.at("palletd_detection_seconds_sum") == Approx(0.075));
  CHECK(s.at("palletd_detection_seconds_bucket{le=\"0.02\"}") == 4);
  CHECK(s.at("palletd_result_latency_seconds_count") == 6);
  CHECK(s.at("palletd_stage_seconds_count{stage=\"layout\"}") == 5);
  CHECK(s.count("palletd_stage_seconds_count{stage=\"total\"}") == 0);
  // The gauges follow the last result: the timeout had no boxes and no height.
  CHECK(s.at("palletd_layer_boxes") == 0);
  CHECK(std::isnan(s.at("palletd_layer_height_above_pallet_meters")));
  f.metrics.observe(ok);
  const auto after = samples(f.metrics.render());
  CHECK(after.at("palletd_layer_boxes") == 12);
  CHECK(after.at("palletd_layer_height_above_pallet_meters") == Approx(1.25));
  CHECK(after.at("palletd_layers_remaining") == 5);
}

TEST_CASE("the service's and the Modbus server's counters are read at each scrape", "[metrics]") {
  Fixture f;
  f.health.triggers = 7;
  f.health.camera_ok = true;
  f.health.camera_losses = 2;
  f.health.grab_timeouts = 3;
  f.modbus.missed_triggers = 4;
  f.modbus.connections_evicted = 70000;
  f.modbus.exceptions_by_code[1] = 5;
  f.modbus.exceptions_by_code[4] = 1;  // a code palletd does not answer appears once it occurs
  f.modbus.open_connections = 3;
  auto s = samples(f.metrics.render());
  CHECK(s.at("palletd_triggers_total") == 7);
  CHECK(s.at("palletd_camera_ok") == 1);
  CHECK(s.at("palletd_camera_losses_total") == 2);
  CHECK(s.at("palletd_grab_timeouts_total") == 3);
  CHECK(s.at("palletd_missed_triggers_total") == 4);
  CHECK(s.at("palletd_modbus_connections_evicted_total") == 70000);
  CHECK(s.at("palletd_modbus_exceptions_total{code=\"01\"}") == 5);
  CHECK(s.at("palletd_modbus_exceptions_total{code=\"0B\"}") == 0);
  CHECK(s.at("palletd_modbus_exceptions_total{code=\"04\"}") == 1);
  CHECK(s.at("palletd_modbus_open_connections") == 3);
  CHECK(s.at("palletd_plc_heartbeat_ok") == 1);
  CHECK(s.at("palletd_build_info{commit=\"abcdef012345\",version=\"1.2.3\"}") == 1);
  CHECK(s.at("palletd_config_info{hash=\"0123abcd\"}") == 1);

  CHECK(s.count("palletd_shadow_results_total{outcome=\"agree\"}") == 0);  // no shadow configured
  f.health.shadow_enabled = true;
  f.health.shadow_runs = 10;
  f.health.shadow_disagreements = 3;
  f.health.shadow_skipped = 1;
  s = samples(f.metrics.render());
  CHECK(s.at("palletd_shadow_results_total{outcome=\"agree\"}") == 7);
  CHECK(s.at("palletd_shadow_results_total{outcome=\"disagree\"}") == 3);
  CHECK(s.at("palletd_shadow_results_total{outcome=\"skipped\"}") == 1);

  f.health.triggers = 8;
  f.health.camera_ok = false;
  f.modbus.plc_heartbeat_lost = true;
  f.hash = "ffff0000";
  s = samples(f.metrics.render());
  CHECK(s.at("palletd_triggers_total") == 8);
  CHECK(s.at("palletd_camera_ok") == 0);
  CHECK(s.at("palletd_plc_heartbeat_ok") == 0);
  CHECK(s.count("palletd_config_info{hash=\"0123abcd\"}") == 0);
  CHECK(s.at("palletd_config_info{hash=\"ffff0000\"}") == 1);
}

TEST_CASE("Prometheus's promtool accepts the exposition text", "[metrics][promtool]") {
  Fixture f;
  ResultSnapshot ok = result(DetectionStatus::kOk, 3, 20.0);
  ok.detection.ambiguity_kinds = {AmbiguityKind::kLevelCheck};
  f.metrics.observe(ok);
  const std::string text = f.metrics.render();
  const std::string path = std::string(PALLETD_BINARY_DIR) + "/tests/metrics/promtool_input.txt";
  {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> out(std::fopen(path.c_str(), "w"), &std::fclose);
    REQUIRE(out);
    REQUIRE(std::fwrite(text.data(), 1, text.size(), out.get()) == text.size());
  }
  // `promtool check metrics` lints the format and the naming conventions (units, _total).
  const std::string command = std::string(PALLETD_PROMTOOL) + " check metrics < " + path + " 2>&1";
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> pipe(popen(command.c_str(), "r"), &pclose);
  REQUIRE(pipe);
  std::string output;
  char buffer[512];
  while (std::fgets(buffer, sizeof buffer, pipe.get()) != nullptr) output += buffer;
  const int status = pclose(pipe.release());
  INFO(output);
  CHECK(status == 0);
  CHECK(output.empty());
}
