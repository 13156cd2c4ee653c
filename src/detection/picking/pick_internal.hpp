// Internals of plan_picks(): footprints as rectangles in the layer frame, and the checks one
// footprint placement has to pass.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "palletd/detection/picking.hpp"

namespace palletd::picking {

/// An oriented rectangle in the layer frame [m].
struct Rect {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector2d axis = Eigen::Vector2d::UnitX();  ///< unit, along `half_long_m`
  double half_long_m = 0.0;
  double half_short_m = 0.0;

  [[nodiscard]] bool contains(const Eigen::Vector2d& p) const;
  [[nodiscard]] Rect grown(double margin_m) const;
  [[nodiscard]] std::array<Eigen::Vector2d, 4> corners() const;
};

/// True when the interiors of the two rectangles overlap (separating axis test).
bool overlap(const Rect& a, const Rect& b);

/// The box's top face as a rectangle.
Rect rect_of(const Box2d& box);

/// One pick: the boxes it takes, the area they cover, and where the footprint goes.
struct Pick {
  std::vector<int> boxes;  ///< indices into the boxes, ascending
  Rect area;               ///< the box, or the row's union
  Rect centred;            ///< the footprint centred on the area
  Rect footprint;          ///< the placement chosen (centred, or flush with the area's sides)
};

/// The checks of one footprint placement. The lasting ones (region of interest, higher level,
/// yaw limits) are the same whatever was picked before and are remembered per pick.
class PlacementCheck {
 public:
  PlacementCheck(const PickSurroundings& surroundings, const GripperParams& gripper,
                 const std::vector<DetectedBox>& boxes);

  [[nodiscard]] const GripperParams& gripper() const { return gripper_; }

  /// The lasting reason the pick cannot be made, or kNone.
  PickBlock lasting_block(const Pick& pick);
  /// Whether the footprint covers a box that still stands and is not taken by the pick.
  [[nodiscard]] bool covers_neighbour(const Pick& pick, const std::vector<char>& standing) const;
  /// The TCP of a footprint: of the footprint's two yaws, the one within the limits nearest their
  /// middle; when neither is within them, the one nearest the middle and `reachable` false.
  [[nodiscard]] TcpPose tcp(const Rect& footprint, bool* reachable = nullptr) const;

 private:
  [[nodiscard]] bool inside_roi(const Rect& area) const;
  [[nodiscard]] bool in_view(const Rect& area) const;
  [[nodiscard]] bool obstacle_in(const Rect& area) const;
  [[nodiscard]] TcpPose pose_of(const Rect& footprint, const Eigen::Vector2d& axis) const;

  const PickSurroundings& surroundings_;
  GripperParams gripper_;
  std::vector<Rect> box_rects_;
  /// By boxes, footprint centre [mm] and turn.
  std::map<std::tuple<std::vector<int>, long, long, long>, PickBlock> lasting_;
};

/// The pick with its first placement that is clear with what stands, or nullopt.
std::optional<Pick> placed(Pick pick, const std::vector<char>& standing, PlacementCheck& check);

/// The largest pick that takes box `seed` with what is still standing, or nullopt. Rows of up to
/// `max_boxes` boxes are tried, largest first, before the box alone.
std::optional<Pick> best_pick(int seed, const std::vector<DetectedBox>& boxes,
                              const std::vector<char>& standing, PlacementCheck& check);

/// The box taken alone: the first placement clear now, or the most lasting reason none is.
struct AloneVerdict {
  std::optional<Pick> clear;
  PickBlock block = PickBlock::kNone;  ///< kNeighbour when a placement is free of lasting blocks
  Rect footprint;                      ///< the clear placement, else the one nearest to clear
};
AloneVerdict alone_pick(int index, const std::vector<DetectedBox>& boxes, const std::vector<char>& standing,
                        PlacementCheck& check);

/// The box alone, the footprint centred on it.
Pick single_pick(int index, const std::vector<DetectedBox>& boxes, const GripperParams& gripper);

}  // namespace palletd::picking
