// palletd metrics: the daemon's counters, gauges and histograms for Prometheus
// (docs/monitoring/README.md lists them). prometheus-cpp builds the families and writes the text
// exposition format; its types stay inside this target.
//
// Two kinds of figures:
//   - per result (observe()): results by status and reason, ambiguous results by reason, the
//     detection, latency and stage time histograms, the last layer's gauges;
//   - cumulative counters the service and the Modbus server keep (triggers, camera faults,
//     connections, exceptions) and live gauges (camera OK, PLC heartbeat OK), read from the
//     MetricsSource at every scrape, so nothing is counted twice.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "palletd/modbus/server.hpp"
#include "palletd/status/snapshot.hpp"

namespace palletd {

/// What the executable was built from (the `palletd_build_info` gauge's labels).
struct BuildInfo {
  std::string version;
  std::string commit;  ///< "" when unknown
};

/// Where the scrape-time figures come from. Every callback may be called from any thread and
/// must be thread-safe; only `health` is required.
struct MetricsSource {
  std::function<ServiceHealth()> health;
  std::function<modbus::ServerStats()> modbus;  ///< optional: no Modbus figures without it
  std::function<std::string()> config_hash;     ///< optional: the `palletd_config_info` label
};

class Metrics {
 public:
  Metrics(MetricsSource source, BuildInfo build);
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  /// Counts one published result. Thread-safe; takes microseconds (no allocation after the
  /// first result of each status, reason and stage).
  void observe(const ResultSnapshot& result);

  /// Every metric in the Prometheus text exposition format (version 0.0.4). Thread-safe.
  [[nodiscard]] std::string render() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palletd
