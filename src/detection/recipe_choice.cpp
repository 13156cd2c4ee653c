// best_fitting_recipe(): the configured recipe whose cartons the frame shows.
#include "palletd/detection/recipe_choice.hpp"

#include <cmath>

namespace palletd {

namespace {

/// Spread of a carton's measured side around its format's nominal size plus half the bulge
/// allowance, for ranking recipes that agree alike [m].
constexpr double kSizeSigma_m = 0.008;

/// How well a detection's layout and measured sizes fit its recipe: the layout confidence,
/// weighted by how close the measured sizes come to the recipe's (unmeasured: as one sigma off).
double fit_of(const Detection& d) {
  const double r = d.recipe_check.size_residual_m;
  const double z = r >= 0.0 ? r / kSizeSigma_m : 1.0;
  return d.layout_confidence * std::exp(-0.5 * z * z);
}

}  // namespace

std::optional<int> best_fitting_recipe(const Frame& frame, const std::vector<RecipeCandidate>& candidates,
                                       const DetectionParams& params, DetectionWorkspace& workspace) {
  std::optional<int> best;
  double best_confidence = -1.0;
  for (const RecipeCandidate& c : candidates) {
    const Detection d = detect(frame, c.formats, params, workspace);
    if (d.status != DetectionStatus::kOk || d.boxes.empty() || !d.recipe_check.agrees) continue;
    if (fit_of(d) > best_confidence) {
      best_confidence = fit_of(d);
      best = c.number;
    }
  }
  return best;
}

}  // namespace palletd
