// palletd metrics (private): the families read at scrape time from the service's and the Modbus
// server's own counters, built as prometheus-cpp MetricFamily values.
#pragma once

#include <string>
#include <vector>

#include <prometheus/metric_family.h>

#include "palletd/metrics/metrics.hpp"

namespace palletd {

/// Trigger, frame and camera fault counters; camera OK and threads alive.
void append_service_families(const ServiceHealth& health, std::vector<prometheus::MetricFamily>& out);
/// Missed triggers, connections, requests, exceptions by code; open connections, PLC heartbeat OK.
void append_modbus_families(const modbus::ServerStats& stats, std::vector<prometheus::MetricFamily>& out);
/// palletd_build_info{version, commit} and palletd_config_info{hash}, both 1.
void append_info_families(const BuildInfo& build, const std::string& config_hash,
                          std::vector<prometheus::MetricFamily>& out);

}  // namespace palletd
