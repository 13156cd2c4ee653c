// Service::status_line(): the one line sd_notify STATUS= and the log show.
#include "palletd/service/service.hpp"

namespace palletd {

std::string Service::status_line() const {
  const ServiceHealth h = health();
  std::string s = h.threads_alive ? "ready" : "degraded";
  s += ": " + std::to_string(h.triggers) + " triggers, " + std::to_string(h.failures) + " failed; camera " +
       h.camera_id + " " + h.camera_state + "; modbus port " + std::to_string(h.modbus_port) + ", " +
       std::to_string(h.modbus_connections) + " client(s)";
  if ((h.cell_health.warnings & modbus::kHealthDrift) != 0)
    s += "; DRIFT: camera moved against its reference";
  if ((h.cell_health.warnings & modbus::kHealthWindowWarnings) != 0) s += "; health warning (see 146)";
  if (h.recording_failures > 0) {
    s += "; recording failed " + std::to_string(h.recording_failures) + " time(s)";
    if (!h.last_recording_error.empty()) s += ", last: " + h.last_recording_error;
  }
  return s;
}

}  // namespace palletd
