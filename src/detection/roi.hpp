// Stage 0b of detect(): the work volume (RegionOfInterest) applied to the organized cloud.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Geometry>

#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"

namespace palletd {

/// Marks the points beside and above the region as without depth (NaN), so that no stage sees
/// them (a cabinet, a robot base, a post). Points below it (the floor, a lower level) stay: they
/// show where the layer ends. Returns "" or why the region cannot
/// be applied (a base-frame region and a frame without camera_to_base).
std::string apply_region_of_interest(const RegionOfInterest& roi, const std::optional<Eigen::Isometry3d>& T_base_camera,
                                     OrganizedCloud& cloud);

}  // namespace palletd
