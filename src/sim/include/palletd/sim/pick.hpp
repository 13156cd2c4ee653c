// palletd sim: what a pick does to the layer, for the check after a pick (issue 23).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "palletd/sim/sim.hpp"

namespace palletd::sim {

/// What the gripper does when it takes a box.
enum class PickEvent {
  kClean,   ///< the box is gone, the rest stand where they stood
  kMissed,  ///< the box still stands
  kDouble,  ///< a neighbour beside it went too
  kDrag,    ///< a neighbour beside it is dragged toward the gap
  kTurn,    ///< a neighbour beside it is pulled by one end: turned, and moved as far as it must
};

/// What happened, with the truth the check is scored against.
struct PickOutcome {
  /// As done: a turn without room is a drag; a drag or a double pick without a neighbour beside
  /// the box, or a drag without 5 mm of room, is clean.
  PickEvent event = PickEvent::kClean;
  std::vector<std::size_t> gone;         ///< indices into Scene::boxes taken off the layer
  std::optional<std::size_t> neighbour;  ///< the neighbour that went, was dragged or turned
  Eigen::Vector2d shift_m = Eigen::Vector2d::Zero();  ///< how far its centre moved [m]
  double turn_rad = 0.0;                              ///< how far it turned [rad]
};

/// Takes `picked` (an index into scene.boxes, a box of the top layer) the way `event` says.
/// The neighbour is the standing box that shares the longest stretch of side with the picked
/// one. Cartons are rigid and do not pass through each other: a drag of 5-40 mm toward the gap
/// is shortened until the neighbour touches no other box, and a turn of 2-5 degrees about one
/// end of the side that faces the gap is made smaller, or moved further into the gap, until it
/// fits; a turn that fits nowhere becomes a drag (a box held on both sides by its row cannot
/// turn in place). Taken boxes are lowered out of sight of the layer.
PickOutcome simulate_pick(Scene& scene, std::size_t picked, PickEvent event, std::uint64_t seed);

const char* to_string(PickEvent event);

/// Takes a box off the layer: lowered out of the camera's sight, as simulate_pick() does.
void take_off(SimBox& box);
/// Whether the box was taken off (take_off()).
bool taken_off(const SimBox& box);

}  // namespace palletd::sim
