// palletd drivers: each driver's options and the camera section of the configuration
// (`camera:` in config/palletd.yaml), owned here and parsed by palletd_config.
#pragma once

#include <optional>
#include <string>

#include "palletd/core/frame.hpp"

namespace palletd {

/// The replay driver (driver: replay).
struct ReplayOptions {
  std::string directory;  ///< folder of frames
  bool loop = true;       ///< start again after the last frame (the folder is listed again)
  double rate_hz = 0.0;   ///< free-running rate [Hz]; 0 = one frame per software_trigger()
  std::optional<Intrinsics> intrinsics_override;
};

/// The Aravis driver (driver: aravis).
struct AravisOptions {
  std::string address;  ///< IP address: opened directly, no broadcast discovery
  std::string serial;   ///< or serial number (discovery); checked against the camera if both
  std::string user_id;  ///< or DeviceUserID (discovery)
  std::string pixel_format = "Coord3D_C16";  ///< Coord3D_C16 | Coord3D_ABC32f | Mono16
  double mono16_scale_m = 0.001;             ///< [m per unit] for Mono16
  int packet_size = 0;                       ///< [bytes]; 0 = negotiate (auto packet size)
  bool packet_resend = true;
  int buffer_count = 8;          ///< stream buffer pool
  bool software_trigger = true;  ///< trigger mode with TriggerSoftware when the camera has it
  /// Free-running: this many timeouts in a row mean the stream stopped (camera faulted).
  int timeouts_before_fault = 2;
  std::optional<Intrinsics> intrinsics_override;
};

/// The OpenNI2 driver (driver: openni2).
struct OpenNI2Options {
  /// Device URI (as `palletctl cameras` / OpenNI::enumerateDevices lists it), a path to an .oni
  /// recording, or empty for the first device the runtime finds.
  std::string uri;
  int width = 640, height = 480, fps = 30;  ///< depth video mode (live devices only)
  double depth_unit_m = 0.001;              ///< 0.001 (DEPTH_1_MM) or 0.0001 (DEPTH_100_UM) [m]
  bool ir_as_intensity = true;              ///< open the IR stream as intensity where there is one
  bool loop = true;                         ///< .oni: start again after the last frame (reopens the file)
  /// Live devices: this many timeouts in a row mean the device stopped streaming (faulted).
  int timeouts_before_fault = 2;
  std::optional<Intrinsics> intrinsics_override;
};

/// Which driver, its options and the settings every driver shares.
struct CameraConfig {
  std::string driver = "replay";  ///< replay | aravis | openni2
  double frame_timeout_ms = 2000.0;
  double reconnect_min_s = 0.5;  ///< first reconnect delay [s], doubling up to reconnect_max_s
  double reconnect_max_s = 10.0;
  /// A call on the camera's control channel (software trigger, probe) not answered within this
  /// clears CameraOK at once, before the vendor library gives up on the call [ms].
  double control_timeout_ms = 1000.0;
  std::optional<Intrinsics> intrinsics_override;  ///< replaces what the camera reports (every driver)
  ReplayOptions replay;
  AravisOptions aravis;
  OpenNI2Options openni2;
};

}  // namespace palletd
