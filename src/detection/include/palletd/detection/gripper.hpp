// The gripper the robot picks with (config `gripper`), and what palletd says about each pick:
// whether the box can be taken now, the TCP pose to take it with, and pick groups for grippers
// that take several boxes at once (shared/spec/detections.md, "Cells, picking and layers").
#pragma once

#include <vector>

#include <Eigen/Core>

namespace palletd {

/// `gripper`: the tool seen from above. Lengths in millimetres as configured.
struct GripperParams {
  /// Footprint of the vacuum field or the clamp, long side along the box's long side [mm].
  Eigen::Vector2d footprint_mm = Eigen::Vector2d(300.0, 200.0);
  /// The TCP relative to the footprint's centre, in the box frame (x along the long side) [mm].
  Eigen::Vector2d tcp_offset_mm = Eigen::Vector2d::Zero();
  int max_boxes = 1;           ///< boxes one pick may take (a row of adjacent boxes of one format)
  double clearance_mm = 10.0;  ///< free space needed around the footprint above the layer [mm]
  double yaw_min_deg = -180.0, yaw_max_deg = 180.0;  ///< TCP yaw the robot can reach [deg]
  double max_group_gap_mm = 20.0;                    ///< widest gap between two boxes taken in one pick [mm]
  /// Anything standing this far above the layer inside the footprint and its clearance blocks
  /// the pick (a higher level, a cell object inside the region of interest) [mm]. Above the
  /// layer's noise and a carton's bulge, below any carton's height.
  double obstacle_height_mm = 30.0;

  friend bool operator==(const GripperParams& a, const GripperParams& b) {
    return a.footprint_mm == b.footprint_mm && a.tcp_offset_mm == b.tcp_offset_mm &&
           a.max_boxes == b.max_boxes && a.clearance_mm == b.clearance_mm && a.yaw_min_deg == b.yaw_min_deg &&
           a.yaw_max_deg == b.yaw_max_deg && a.max_group_gap_mm == b.max_group_gap_mm &&
           a.obstacle_height_mm == b.obstacle_height_mm;
  }
};

/// Why a box cannot be picked now, the most lasting reason first.
enum class PickBlock {
  kNone,
  kRoi,          ///< the footprint and its clearance reach out of the region of interest (a wall)
                 ///< or out of the camera's view (what stands there is unknown)
  kHigherLevel,  ///< something higher than the layer stands under the footprint or its clearance
  kYawLimits,    ///< neither of the box's two yaws (it is symmetric by 180°) is within the limits
  kNeighbour,    ///< the footprint covers a neighbour that has to go first
};
/// "", "roi", "higher_level", "yaw_limits", "neighbour" (the JSON words).
const char* to_string(PickBlock block);

/// A TCP pose: base frame when the camera is calibrated, else camera frame.
struct TcpPose {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  double yaw_deg = 0.0;  ///< (-180, 180], about the frame's z axis
  bool base_frame = false;
};

/// What palletd says about picking one box.
struct BoxPick {
  bool pickable = false;  ///< the robot can take it now (alone, or in one of `Detection::groups`)
  PickBlock blocked_by = PickBlock::kNone;
  TcpPose tcp;  ///< the TCP to take this box alone
};

/// Boxes taken in one pick: one box, or a row of adjacent boxes under a wide footprint.
struct PickGroup {
  std::vector<int> boxes;  ///< indices into Detection::boxes
  TcpPose tcp;
  int pick_index = 0;  ///< order of the groups, 0 first
};

}  // namespace palletd
