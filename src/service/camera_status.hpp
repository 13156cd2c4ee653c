// The camera's state and counters as the status block and the service's health show them.
#pragma once

#include <cstdint>

#include "palletd/drivers/camera.hpp"
#include "palletd/modbus/handshake.hpp"
#include "palletd/status/snapshot.hpp"

#include "acquisition.hpp"

namespace palletd {

/// The status block's camera part (CameraOK, error 4 while disconnected, counters 115..129).
/// `running`: the service accepts triggers (Ready).
modbus::ServiceStatus camera_status(const CameraSupervisor& cam, std::uint64_t camera_restarts, bool running);

/// The camera's state and counters into the service's health.
void add_camera_health(const Acquisition& acquisition, ServiceHealth& health);

}  // namespace palletd
