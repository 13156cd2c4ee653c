// Stage 8b of detect(): which boxes the gripper can take now, with which TCP pose, in which order,
// and which of them one pick of a wide gripper takes together.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/gripper.hpp"

namespace palletd {

/// What the picks are checked against, besides the layer's own boxes.
struct PickSurroundings {
  Eigen::Isometry3d T_camera_layer = Eigen::Isometry3d::Identity();  ///< layer -> camera
  /// Layer-frame x-y [m] of what stands higher than the layer (obstacles_above_layer()).
  std::vector<Eigen::Vector2d> obstacles_layer_m;
  std::optional<RegionOfInterest> roi;             ///< the work volume's walls
  std::optional<Eigen::Isometry3d> T_base_camera;  ///< TCP poses in the base frame when given
  /// The camera's image: a footprint and its clearance must lie in view, or what stands there is
  /// unknown. Not checked when not valid().
  Intrinsics intrinsics;
};

/// What stands more than `min_height_m` above the layer plane between the region of interest's
/// walls (above its top too: a cabinet's top the region cuts off is still in the robot's way), in
/// the layer frame, one point per 5 mm cell. A pixel counts only with at least three of its eight
/// neighbours above too: a lone flying pixel is no obstacle, a post 20 mm thick is. The outer ring
/// of pixels around a solid obstacle's inside does not count: it straddles the obstacle's edge
/// (mixed or fattened pixels outside it); a bar two pixels wide, without an inside, counts whole.
/// `rays` must match the frame's intrinsics; a base-frame region needs `T_base_camera`.
std::vector<Eigen::Vector2d> obstacles_above_layer(const Frame& frame, const RayTable& rays,
                                                   const Eigen::Isometry3d& T_camera_layer,
                                                   double min_height_m, const RegionOfInterest* roi,
                                                   const std::optional<Eigen::Isometry3d>& T_base_camera);

/// Sets every box's `pick` and returns the picks that can be made now (Detection::groups).
///
/// `boxes` come in the configured pick order (pick_index 0, 1, ...). The robot's picks are played
/// through one after another: each time, the first box in that order that can be taken with what
/// still stands, with the largest row of up to `max_boxes` boxes it can be taken with. A footprint
/// larger than what it takes sits centred on it, else flush with one or two of its sides so that it
/// overhangs the layer's outside or a gap left by an earlier pick. The new order: the picks that
/// can be made now, then the others as the play-through made them, then the boxes that stay
/// blocked (a wall, a higher level, the yaw limits). `boxes` are re-sorted by the new pick_index.
std::vector<PickGroup> plan_picks(const PickSurroundings& surroundings, const GripperParams& gripper,
                                  std::vector<DetectedBox>& boxes);

}  // namespace palletd
