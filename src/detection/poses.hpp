// Stage 6 of detect(): boxes from the layer frame to the camera frame and the robot base frame,
// and the order in which the robot picks them.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "palletd/detection.hpp"

namespace palletd {

/// Camera-frame (and, when T_base_camera is given, base-frame) poses of layer-frame boxes,
/// with pick_index assigned by `order`. `scores` is parallel to `boxes` (may be empty).
std::vector<DetectedBox> to_detected_boxes(const std::vector<Box2d>& boxes, const std::vector<double>& scores,
                                           const Eigen::Isometry3d& T_camera_layer,
                                           const std::optional<Eigen::Isometry3d>& T_base_camera,
                                           PickOrder order);

/// Yaw of a box's long axis about the base z axis [deg], folded to (-90, 90]: a box's long axis has
/// no sign, so the gripper is given the rotation of smaller magnitude.
double box_yaw_deg(const Eigen::Vector3d& long_axis_base);

}  // namespace palletd
