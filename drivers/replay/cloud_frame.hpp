// Organized point clouds (PCD, PLY) as depth frames, for the replay driver.
#pragma once

#include <string>

#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"

namespace palletd {

/// Whether `path` names a cloud file the replay driver reads (*.pcd or *.ply, case-insensitive).
bool is_cloud_path(const std::string& path);

/// Reads an organized cloud (PCL's PCD or PLY; camera frame, metres; NaN or z <= 0 = no
/// measurement) into a frame: depth = Z along the optical axis in 0.1 mm units
/// (depth_scale_m = 1e-4, clamped to 6.5535 m), intrinsics estimated by least squares from
/// u = fx X/Z + cx, v = fy Y/Z + cy over all valid pixels (no distortion), intensity from an
/// "intensity" field (rounded to 16 bits) when the cloud has one.
/// Errors: unreadable file, unorganized cloud (height 1), fewer than 3 valid points, or points that
/// do not follow a pinhole projection (RMS residual above half a pixel).
Expected<Frame> read_cloud_frame(const std::string& path);

}  // namespace palletd
