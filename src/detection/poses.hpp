// Stage 6 of detect(): boxes from the layer frame to the camera frame and the robot base frame,
// and the order in which the robot picks them.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "palletd/detection/detection.hpp"

namespace palletd {

/// Camera-frame (and, when T_base_camera is given, base-frame) poses of layer-frame boxes,
/// with pick_index assigned by `order`. `scores` and `partly_unseen` are parallel to `boxes` (either
/// may be empty: 0 and false).
std::vector<DetectedBox> to_detected_boxes(const std::vector<LayoutBox>& boxes,
                                           const Eigen::Isometry3d& T_camera_layer,
                                           const std::optional<Eigen::Isometry3d>& T_base_camera,
                                           PickOrder order);

/// Sets the box's camera-frame pose (center, long_axis, normal) and, with T_base_camera, its
/// base-frame one from its layer-frame box `in_layer`.
void place_from_layer(DetectedBox& box, const Eigen::Isometry3d& T_camera_layer,
                      const std::optional<Eigen::Isometry3d>& T_base_camera);

}  // namespace palletd
