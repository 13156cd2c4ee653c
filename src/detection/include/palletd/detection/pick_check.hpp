// The check after a pick: is the picked box gone, is every other box where it was? Known boxes
// are fitted to the frame after the pick (no layout search): each box's top is looked for where
// it stood, and its sides where the depth steps down beside it, in the frame before and after.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"

namespace palletd {

/// `check`: what counts as a moved box (config).
struct PickCheckParams {
  double tolerance_mm = 5.0;   ///< a box whose centre moved further has moved
  double tolerance_deg = 1.0;  ///< ... or that turned further
};

/// The check's answer, worst first.
enum class PickVerdict {
  kPickOk,          ///< the picked boxes are gone, every other box is where it was
  kBoxStillThere,   ///< a picked box still stands: a missed pick
  kExtraBoxGone,    ///< a box that was not picked is gone: a double pick
  kNeighbourMoved,  ///< a box that was not picked moved or turned beyond the tolerance
  kFailed,          ///< the frame or the last result cannot be checked (message says why)
};
/// "pick_ok", "box_still_there", "extra_box_gone", "neighbour_moved", "failed".
const char* to_string(PickVerdict verdict);

/// One box of the last result, after the pick.
struct BoxCheck {
  int box = 0;              ///< index into the last result's boxes
  bool picked = false;      ///< the PLC said it was taken
  bool present = false;     ///< its top is still seen where it stood
  double seen_share = 0.0;  ///< share of its top (inset) seen at the layer's height after the pick
  double shift_mm = 0.0;    ///< how far its centre moved (present boxes)
  double turn_deg = 0.0;    ///< how far it turned
  int sides_seen = 0;       ///< sides whose edge was measured after the pick (0..4)
  /// Not picked, present, and moved or turned beyond the tolerance by more than the sides'
  /// scatter explains.
  bool moved = false;
  DetectedBox now;  ///< its pose after the pick (the last one when it did not move)
};

struct PickCheck {
  PickVerdict verdict = PickVerdict::kFailed;
  std::string message;
  std::vector<BoxCheck> boxes;  ///< every box of the last result, in its order
  /// The sides' steps against the boxes' sides the check measured in the frame before, or took
  /// from the last result where that frame showed too few sides (LayerDiagnostics).
  std::optional<double> side_steps_facing_m, side_steps_away_m;
  std::map<std::string, double> timing_ms;
};

/// Compares the frame after a pick with the last result and the frame it came from.
/// `picked`: indices into `last.boxes` the robot took. `before` must be the frame `last` was
/// detected on (same camera and intrinsics; its camera_to_base gives the moved boxes' base
/// poses). Never throws: a bad frame gives kFailed.
PickCheck check_pick(const Frame& before, const Detection& last, const Frame& after,
                     const std::vector<int>& picked, const PickCheckParams& check);

/// The last result as it stands after a checked pick, without a layout search: the boxes the check
/// found gone are dropped (picked or not), every other box takes its pose after the pick
/// (`BoxCheck::now`), the pick order keeps the last order, and with a gripper
/// (`params.gripper`) the picks are planned again on the frame after. A check that failed leaves
/// `last` as it was. `check` must come from check_pick() on `last` and `after`.
Detection after_pick(const Detection& last, const PickCheck& check, const Frame& after,
                     const DetectionParams& params);

}  // namespace palletd
