// palletd detection: which of the configured recipes a frame shows. Run where a layer disagreed
// with its recipe (status recipe_mismatch), so that the PLC can ask for the right one.
#pragma once

#include <optional>
#include <vector>

#include "palletd/detection/detection.hpp"

namespace palletd {

/// A recipe as the detection sees it: its number and its formats.
struct RecipeCandidate {
  int number = 0;
  std::vector<BoxFormat> formats;
};

/// The candidate whose cartons the frame shows best: detect() with each; among those whose layout
/// is ok and whose measured sides agree with their formats, the highest layout confidence times a
/// Gaussian weight of the measured sizes' distance from the band cartons are built in
/// (RecipeCheck::size_residual_m, 8 mm as one sigma; unmeasured counts as one sigma): a 412 mm
/// carton is a 400 mm format built 3 % over, not a 420 mm one (the first listed on a tie). Null
/// when none fits. Costs one detection per candidate.
std::optional<int> best_fitting_recipe(const Frame& frame, const std::vector<RecipeCandidate>& candidates,
                                       const DetectionParams& params, DetectionWorkspace& workspace);

/// Which of the other configured recipes (`candidates`) the frame shows, where its own recipe
/// failed on it. After recipe_mismatch: best_fitting_recipe() into recipe_check.best_recipe.
/// After no_layout on a layer found (the recipe's boxes tile none of it, or too little): where
/// another recipe lays the layer out with its measured sides agreeing, the layer holds other
/// cartons, and the detection becomes recipe_mismatch naming that recipe (still without boxes);
/// where none does, it stays no_layout. Any other detection is left as it is.
void name_recipe_shown(const Frame& frame, const std::vector<RecipeCandidate>& candidates,
                       const DetectionParams& params, DetectionWorkspace& workspace, Detection& detection);

}  // namespace palletd
