#include "scrape_families.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <utility>

namespace palletd {
namespace {

using prometheus::ClientMetric;
using prometheus::MetricFamily;
using prometheus::MetricType;

ClientMetric counter_value(double value, std::vector<ClientMetric::Label> labels = {}) {
  ClientMetric m;
  m.label = std::move(labels);
  m.counter.value = value;
  return m;
}

ClientMetric gauge_value(double value, std::vector<ClientMetric::Label> labels = {}) {
  ClientMetric m;
  m.label = std::move(labels);
  m.gauge.value = value;
  return m;
}

void add_counter(std::vector<MetricFamily>& out, const char* name, const char* help, std::uint64_t value) {
  out.push_back(MetricFamily{name, help, MetricType::Counter, {counter_value(static_cast<double>(value))}});
}

void add_gauge(std::vector<MetricFamily>& out, const char* name, const char* help, double value) {
  out.push_back(MetricFamily{name, help, MetricType::Gauge, {gauge_value(value)}});
}

/// "01", "0B": the exception code as the Modbus application protocol writes it.
std::string code_label(std::size_t code) {
  char text[8];
  std::snprintf(text, sizeof text, "%02zX", code);
  return text;
}

/// The health window's means (NaN until a frame measured them, like the ratio without a noise
/// model), its warnings and the drift (NaN while not measured).
void append_cell_health_families(const CellHealth& c, std::vector<MetricFamily>& out) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::pair<const char*, const std::optional<double>*> ratios[] = {
      {"invalid", &c.invalid_fraction}, {"flying", &c.flying_fraction}, {"saturated", &c.saturated_fraction}};
  MetricFamily pixels{"palletd_health_pixel_ratio",
                      "Mean share of pixels over the health window: invalid (no depth, of the region of "
                      "interest), flying (mixed, at the layer's edges), saturated",
                      MetricType::Gauge,
                      {}};
  for (const auto& [kind, value] : ratios) pixels.metric.push_back(gauge_value(value->value_or(nan), {{"kind", kind}}));
  out.push_back(std::move(pixels));
  add_gauge(out, "palletd_health_plane_noise_meters", "Mean robust sigma of the layer plane over the window",
            c.plane_noise_mm ? *c.plane_noise_mm / 1000.0 : nan);
  add_gauge(out, "palletd_health_noise_ratio", "Mean layer plane noise over the camera's noise model",
            c.noise_ratio.value_or(nan));
  MetricFamily warnings{"palletd_health_warning",
                        "1 while a health check is beyond its limit (status word bits 9 and 10)",
                        MetricType::Gauge,
                        {}};
  const std::pair<const char*, std::uint16_t> checks[] = {{"invalid", modbus::kHealthInvalid},
                                                          {"flying", modbus::kHealthFlying},
                                                          {"saturated", modbus::kHealthSaturated},
                                                          {"noise", modbus::kHealthNoise},
                                                          {"drift", modbus::kHealthDrift}};
  for (const auto& [check, bit] : checks)
    warnings.metric.push_back(gauge_value((c.warnings & bit) != 0 ? 1.0 : 0.0, {{"check", check}}));
  out.push_back(std::move(warnings));
  add_gauge(out, "palletd_camera_drift_measured",
            "1 when the last frame was compared with the drift reference", c.drift_measured ? 1.0 : 0.0);
  add_gauge(out, "palletd_camera_drift_shift_meters", "Camera shift against the drift reference",
            c.drift_measured ? c.drift_shift_mm / 1000.0 : nan);
  add_gauge(out, "palletd_camera_drift_angle_degrees", "Camera turn against the drift reference",
            c.drift_measured ? c.drift_angle_deg : nan);
}

}  // namespace

void append_service_families(const ServiceHealth& h, std::vector<MetricFamily>& out) {
  add_counter(out, "palletd_triggers_total", "Triggers taken by the pipeline", h.triggers);
  add_counter(out, "palletd_frames_total", "Frames received from the camera", h.frames);
  add_counter(out, "palletd_camera_losses_total", "Times the camera was found gone", h.camera_losses);
  add_counter(out, "palletd_camera_reconnects_total", "Camera re-opened after it was lost", h.reconnects);
  add_counter(out, "palletd_camera_restarts_total",
              "Trigger-mode camera restarted after frame timeouts in a row", h.camera_restarts);
  add_counter(out, "palletd_grab_timeouts_total", "Grabs that ended without a frame in time",
              h.grab_timeouts);
  add_counter(out, "palletd_incomplete_frames_total",
              "Frames the driver refused (missing packets, wrong size or format)", h.incomplete_frames);
  add_counter(out, "palletd_dropped_frames_total", "Frames the camera sent that were lost", h.dropped_frames);
  add_counter(out, "palletd_resent_packets_total", "GigE Vision packets resent on request", h.resent_packets);
  add_counter(out, "palletd_recordings_total", "Frames recorded", h.recordings);
  add_counter(out, "palletd_recording_failures_total", "Recordings that failed", h.recording_failures);
  if (h.shadow_enabled || h.shadow_runs > 0) {
    MetricFamily shadow{
        "palletd_shadow_results_total",
        "Frames the shadow configuration (shadow_config) ran on: agree, disagree; skipped when busy",
        MetricType::Counter,
        {}};
    const double agree = static_cast<double>(h.shadow_runs - std::min(h.shadow_runs, h.shadow_disagreements));
    shadow.metric.push_back(counter_value(agree, {{"outcome", "agree"}}));
    shadow.metric.push_back(
        counter_value(static_cast<double>(h.shadow_disagreements), {{"outcome", "disagree"}}));
    shadow.metric.push_back(counter_value(static_cast<double>(h.shadow_skipped), {{"outcome", "skipped"}}));
    out.push_back(std::move(shadow));
  }
  add_gauge(out, "palletd_camera_ok", "1 while the camera is connected and delivering frames",
            h.camera_ok ? 1.0 : 0.0);
  append_cell_health_families(h.cell_health, out);
  add_gauge(out, "palletd_threads_alive", "1 while every service thread loops (the watchdog's condition)",
            h.threads_alive ? 1.0 : 0.0);
}

void append_modbus_families(const modbus::ServerStats& s, std::vector<MetricFamily>& out) {
  add_counter(out, "palletd_missed_triggers_total", "Triggers refused while Busy or not Ready",
              s.missed_triggers);
  add_counter(out, "palletd_modbus_connections_accepted_total", "Modbus connections accepted",
              s.connections_accepted);
  add_counter(out, "palletd_modbus_connections_evicted_total",
              "Modbus connections closed for a newer one at modbus.max_connections", s.connections_evicted);
  add_counter(out, "palletd_modbus_connections_refused_total", "Modbus connections refused by modbus.allow",
              s.connections_refused);
  add_counter(out, "palletd_modbus_connections_idle_closed_total", "Modbus connections closed as idle",
              s.connections_idle_closed);
  add_counter(out, "palletd_modbus_requests_total", "Modbus requests handled", s.requests);
  MetricFamily exceptions{"palletd_modbus_exceptions_total",
                          "Modbus exception responses by exception code",
                          MetricType::Counter,
                          {}};
  for (std::size_t code = 1; code < s.exceptions_by_code.size(); ++code) {
    // The codes palletd answers always have a series; others only once they occur.
    const bool answered = code == 1 || code == 2 || code == 3 || code == 0x0B;
    if (!answered && s.exceptions_by_code[code] == 0) continue;
    exceptions.metric.push_back(
        counter_value(static_cast<double>(s.exceptions_by_code[code]), {{"code", code_label(code)}}));
  }
  out.push_back(std::move(exceptions));
  add_gauge(out, "palletd_modbus_open_connections", "Modbus connections open now",
            static_cast<double>(s.open_connections));
  add_gauge(out, "palletd_plc_heartbeat_ok", "0 once the PLC heartbeat watch fired (error 6), else 1",
            s.plc_heartbeat_lost ? 0.0 : 1.0);
}

void append_info_families(const BuildInfo& build, const std::string& config_hash,
                          std::vector<MetricFamily>& out) {
  out.push_back(MetricFamily{"palletd_build_info",
                             "The running palletd's version and commit (value 1)",
                             MetricType::Gauge,
                             {gauge_value(1.0, {{"commit", build.commit}, {"version", build.version}})}});
  out.push_back(MetricFamily{"palletd_config_info",
                             "Hash of the configuration file in force (value 1)",
                             MetricType::Gauge,
                             {gauge_value(1.0, {{"hash", config_hash}})}});
}

}  // namespace palletd
