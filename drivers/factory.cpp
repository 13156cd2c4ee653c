// make_camera(): the one place that maps CameraConfig onto a driver.
#include <stdexcept>

#include "aravis/aravis_camera.hpp"
#include "openni2/openni2_camera.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/drivers/camera_config.hpp"
#include "replay/replay_camera.hpp"

namespace palletd {

std::unique_ptr<Camera> make_camera(const CameraConfig& config) {
  if (config.driver == "replay") {
    if (config.replay.directory.empty()) {
      throw std::invalid_argument("camera.replay.directory: the replay driver needs a folder of frames");
    }
    ReplayOptions o = config.replay;
    o.intrinsics_override = config.intrinsics_override;
    return std::make_unique<ReplayCamera>(std::move(o));
  }
  if (config.driver == "aravis") {
    const AravisOptions& a = config.aravis;
    if (a.pixel_format != "Coord3D_C16" && a.pixel_format != "Coord3D_ABC32f" && a.pixel_format != "Mono16") {
      throw std::invalid_argument("camera.aravis.pixel_format: '" + a.pixel_format +
                                  "' (expected Coord3D_C16, Coord3D_ABC32f or Mono16)");
    }
    AravisOptions o = a;
    o.intrinsics_override = config.intrinsics_override;
    return std::make_unique<AravisCamera>(std::move(o));
  }
  if (config.driver == "openni2") {
    const OpenNI2Options& n = config.openni2;
    if (n.depth_unit_m != 0.001 && n.depth_unit_m != 0.0001) {
      throw std::invalid_argument("camera.openni2.depth_unit_m: " + std::to_string(n.depth_unit_m) +
                                  " (expected 0.001 for 1 mm or 0.0001 for 100 um)");
    }
    OpenNI2Options o = n;
    o.intrinsics_override = config.intrinsics_override;
    return std::make_unique<OpenNI2Camera>(std::move(o));
  }
  throw std::invalid_argument("camera.driver: unknown driver '" + config.driver +
                              "' (expected replay, aravis or openni2)");
}

}  // namespace palletd
