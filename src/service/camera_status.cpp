// The camera's state and counters for the status block and the health (camera_status.hpp).
#include "camera_status.hpp"

#include <algorithm>

namespace palletd {

modbus::ServiceStatus camera_status(const CameraSupervisor& cam, std::uint64_t camera_restarts,
                                    bool running) {
  modbus::ServiceStatus status;
  const CameraCounters c = cam.counters();
  status.ready = running;
  status.camera_ok = cam.camera_ok();
  // Not streaming after a fault (also while closed between reconnect attempts) or after a
  // failed attempt: disconnected. Closed before the first attempt is just starting up.
  if (!status.camera_ok && running &&
      (cam.state() != CameraState::kClosed || c.faults > 0 || cam.seconds_to_retry() > 0.0)) {
    status.error = modbus::ErrorCode::kCameraDisconnected;
    status.error_detail = static_cast<std::uint16_t>(std::min<std::uint64_t>(c.faults, 65535));
  }
  status.acquisition_id = static_cast<std::uint16_t>(c.frames & 0xFFFF);
  status.frames_grabbed = static_cast<std::uint32_t>(c.frames);
  status.camera_reconnects = static_cast<std::uint16_t>(std::min<std::uint64_t>(c.reconnects, 65535));
  // 32-bit counters wrap (a PLC computes differences modulo 2^32).
  const auto u32 = [](std::uint64_t v) { return static_cast<std::uint32_t>(v & 0xFFFFFFFFu); };
  modbus::CameraFaultCounters& f = status.camera_faults;
  f.incomplete_frames = u32(c.incomplete);
  f.grab_timeouts = u32(c.timeouts);
  f.dropped_frames = u32(c.drops);
  f.camera_losses = u32(c.faults);
  f.camera_restarts = u32(camera_restarts);
  f.resent_packets = u32(c.resent);
  return status;
}

void add_camera_health(const Acquisition& acquisition, ServiceHealth& h) {
  const CameraSupervisor& cam = acquisition.camera();
  h.camera_ok = cam.camera_ok();
  h.camera_state = to_string(cam.state());
  h.camera_id = cam.identity().id();
  const CameraCounters c = cam.counters();
  h.frames = c.frames;
  h.reconnects = c.reconnects;
  h.camera_restarts = acquisition.camera_restarts();
  h.incomplete_frames = c.incomplete;
  h.grab_timeouts = c.timeouts;
  h.dropped_frames = c.drops;
  h.camera_losses = c.faults;
  h.resent_packets = c.resent;
}

}  // namespace palletd
