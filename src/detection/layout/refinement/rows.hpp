// Rows of cartons larger than their format (private to the refinement): where the search's
// nominal boxes start the fit, and gaps the fit opens where the layer shows carton top.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "refinement/refine_internal.hpp"
#include "refinement/refine_joint.hpp"

namespace palletd::layout_detail {

/// The search packs boxes of the nominal format from one side of the outline; real cartons are
/// built up to max_oversize over it and stand with gaps, so along a row of n cartons the far ones
/// lie up to n times that from where the search put them, beyond the window their sides are
/// looked for in. Where the boxes `ev` (in the component's frame) together span less of the
/// component than its `outline` bounds do (by more than half the window, and by no more than
/// cartons of max_oversize plus 3 % of gaps: a larger shortfall is a box missing, not grown ones),
/// their centres are spread over the outline's extent along that axis.
void stretch_to_outline(const Rect& outline, double window_m, double max_oversize, std::vector<BoxEvidence>& ev);

/// Boxes the fit leaves apart by a gap the layer's points fill: the depth shows carton top where
/// the fit puts a gap wider than two pixels (the search packed nominal boxes from both ends of a
/// row of larger ones, and no seam says where the space goes), so the pair stands pressed.
/// Pairs up to reach_m apart; returned as contacts (a's +side on b's -side).
std::vector<Contact> filled_gaps(const std::vector<BoxEvidence>& ev, const std::vector<JointBox>& fitted,
                                 const std::vector<Contact>& contacts, double margin_m, double reach_m);

}  // namespace palletd::layout_detail
