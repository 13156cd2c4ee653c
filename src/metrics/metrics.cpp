#include "palletd/metrics/metrics.hpp"

#include <cctype>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <prometheus/counter.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include "palletd/modbus/register_words.hpp"

#include "scrape_families.hpp"

namespace palletd {
namespace {

/// Detection and latency buckets [s]: a detection takes 10-100 ms on a cell PC, a trigger's
/// latency adds the frame's wait; the top buckets catch a stalled camera.
prometheus::Histogram::BucketBoundaries time_buckets() {
  return {0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0};
}

/// An error name as a label value: "frame timeout" -> "frame_timeout".
std::string label_of(const char* words) {
  std::string out = words;
  for (char& c : out) {
    c = c == ' ' ? '_' : static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  return out;
}

/// The status and reason labels of one result: what the PLC was told, in the words of
/// shared/spec/detections.md ("failed" with why, else ok / no_boxes / empty / slip_sheet).
prometheus::Labels result_labels(const ResultSnapshot& r) {
  if (r.error != modbus::ErrorCode::kNone && r.error != modbus::ErrorCode::kDetectionFailed)
    return {{"status", "failed"}, {"reason", label_of(modbus::error_name(r.error))}};
  const Detection& d = r.detection;
  if (is_failure(d.status)) return {{"status", "failed"}, {"reason", to_string(d.status)}};
  if (d.status == DetectionStatus::kOk && d.boxes.empty()) return {{"status", "no_boxes"}};
  return {{"status", to_string(d.status)}};
}

}  // namespace

class Metrics::Impl {
 public:
  Impl(MetricsSource source, BuildInfo build)
      : source_(std::move(source)),
        build_(std::move(build)),
        registry_(std::make_shared<prometheus::Registry>()),
        results_(prometheus::BuildCounter()
                     .Name("palletd_results_total")
                     .Help("Results published, by status (ok, no_boxes, empty, slip_sheet, failed) and the "
                           "failure's reason")
                     .Register(*registry_)),
        ambiguous_(prometheus::BuildCounter()
                       .Name("palletd_ambiguous_results_total")
                       .Help("Results flagged ambiguous, by reason (one count per reason that holds)")
                       .Register(*registry_)),
        detection_(prometheus::BuildHistogram()
                       .Name("palletd_detection_seconds")
                       .Help("Detection wall time per result that ran a detection")
                       .Register(*registry_)
                       .Add({}, time_buckets())),
        latency_(prometheus::BuildHistogram()
                     .Name("palletd_result_latency_seconds")
                     .Help("Trigger edge to ResultReady")
                     .Register(*registry_)
                     .Add({}, time_buckets())),
        stages_(prometheus::BuildHistogram()
                    .Name("palletd_stage_seconds")
                    .Help("Detection time per pipeline stage")
                    .Register(*registry_)),
        boxes_(gauge("palletd_layer_boxes", "Boxes of the last result's layer")),
        height_(gauge("palletd_layer_height_above_pallet_meters",
                      "The last result's layer above the pallet's top [m]; NaN when the pallet height is not "
                      "configured")),
        layers_(
            gauge("palletd_layers_remaining",
                  "Layers left on the pallet counting the top one, from the last result; NaN when unknown")) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    height_.Set(nan);
    layers_.Set(nan);
  }

  void observe(const ResultSnapshot& r) {
    results_.Add(result_labels(r)).Increment();
    const Detection& d = r.detection;
    for (const AmbiguityKind kind : d.ambiguity_kinds)
      ambiguous_.Add({{"reason", to_string(kind)}}).Increment();
    if (r.latency_ms > 0.0) latency_.Observe(r.latency_ms / 1000.0);
    if (r.frame) {  // a detection ran
      for (const auto& [stage, ms] : d.timing_ms) {
        if (stage == "total") {
          detection_.Observe(ms / 1000.0);
        } else {
          stages_.Add({{"stage", stage}}, time_buckets()).Observe(ms / 1000.0);
        }
      }
    }
    const double nan = std::numeric_limits<double>::quiet_NaN();
    boxes_.Set(static_cast<double>(d.boxes.size()));
    height_.Set(d.height_above_pallet_m.value_or(nan));
    layers_.Set(d.layers_remaining ? static_cast<double>(*d.layers_remaining) : nan);
  }

  prometheus::Gauge& gauge(const std::string& name, const std::string& help) {
    return prometheus::BuildGauge().Name(name).Help(help).Register(*registry_).Add({});
  }

  std::string render() const {
    std::vector<prometheus::MetricFamily> families = registry_->Collect();
    const ServiceHealth health = source_.health ? source_.health() : ServiceHealth{};
    append_service_families(health, families);
    if (source_.modbus) append_modbus_families(source_.modbus(), families);
    append_info_families(build_, source_.config_hash ? source_.config_hash() : std::string{}, families);
    return prometheus::TextSerializer().Serialize(families);
  }

 private:
  MetricsSource source_;
  BuildInfo build_;
  std::shared_ptr<prometheus::Registry> registry_;
  prometheus::Family<prometheus::Counter>& results_;
  prometheus::Family<prometheus::Counter>& ambiguous_;
  prometheus::Histogram& detection_;
  prometheus::Histogram& latency_;
  prometheus::Family<prometheus::Histogram>& stages_;
  prometheus::Gauge& boxes_;
  prometheus::Gauge& height_;
  prometheus::Gauge& layers_;
};

Metrics::Metrics(MetricsSource source, BuildInfo build)
    : impl_(std::make_unique<Impl>(std::move(source), std::move(build))) {}
Metrics::~Metrics() = default;
void Metrics::observe(const ResultSnapshot& result) { impl_->observe(result); }
std::string Metrics::render() const { return impl_->render(); }

}  // namespace palletd
