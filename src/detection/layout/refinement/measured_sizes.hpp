// Private to the refinement: box side lengths measured from the side observations alone (no
// prior), for the recipe check (recipe_check.hpp).
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "refine_joint.hpp"

namespace palletd::layout_detail {

/// Box k's extent along frame x and y from its own two opposite sides: the + side's position
/// minus the - side's; -1 along an axis where either was not measured.
Eigen::Vector2d measured_extent(const std::vector<SideObservation>& sides, std::size_t k);

/// Box k's extent as its share of a run of boxes pressed together (no seam seen between them,
/// `contacts`) whose outer two sides were measured: the run's length over its box count, where
/// the run is a plain row (each box touches one box on either side) of boxes of one nominal size
/// (`boxes`). An upper bound: gaps the camera did not show count in. -1 where there is no run.
Eigen::Vector2d run_extent(const std::vector<SideObservation>& sides, const std::vector<Contact>& contacts,
                           const std::vector<JointBox>& boxes, std::size_t k);

}  // namespace palletd::layout_detail
