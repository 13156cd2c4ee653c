// palletd drivers, private: each driver's own options table (camera.replay, camera.aravis,
// camera.openni2), defined in the driver's folder.
#pragma once

#include "palletd/config_table/table.hpp"
#include "palletd/drivers/camera_config.hpp"

namespace palletd {

const config_table::Table<ReplayOptions>& replay_table();
const config_table::Table<AravisOptions>& aravis_table();
const config_table::Table<OpenNI2Options>& openni2_table();

}  // namespace palletd
