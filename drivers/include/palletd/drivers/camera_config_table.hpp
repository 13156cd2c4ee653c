// palletd drivers: how the `camera:` section of the configuration binds to CameraConfig (each
// driver's folder binds its own options). Read by palletd_config, which links palletd_config_table.
#pragma once

#include "palletd/config_table/table.hpp"
#include "palletd/drivers/camera_config.hpp"

namespace palletd {

/// The `camera:` section: driver, timeouts, the intrinsics override and each driver's options.
const config_table::Table<CameraConfig>& camera_table();

}  // namespace palletd
