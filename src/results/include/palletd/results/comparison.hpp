// palletd results: two detections of the same frame compared, as an integrator checks a parameter
// change before `systemctl reload` (palletctl compare, docs/commissioning.md).
#pragma once

#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"

namespace palletd {

/// What differs between detection A and B of one frame. Boxes are paired nearest centre first
/// (camera frame); a box without a partner within `moved_mm` counts as moved by its distance to
/// the nearest one left, or as unpaired when the other has fewer boxes.
struct DetectionDifference {
  bool status_differs = false;
  bool count_differs = false;
  bool ambiguous_differs = false;
  bool format_differs = false;  ///< a paired box has another format
  int boxes_moved = 0;          ///< paired boxes whose centres are more than moved_mm apart
  double max_move_mm = 0.0;     ///< the largest centre distance of a paired box
  [[nodiscard]] bool any() const {
    return status_differs || count_differs || ambiguous_differs || format_differs || boxes_moved > 0;
  }
  /// "status ok -> empty; boxes 12 -> 11; 2 boxes moved (max 38.0 mm)": the differences in words.
  [[nodiscard]] std::string describe(const Detection& a, const Detection& b) const;
};

DetectionDifference compare_detections(const Detection& a, const Detection& b, double moved_mm);

}  // namespace palletd
