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

void name_recipe_shown(const Frame& frame, const std::vector<RecipeCandidate>& candidates,
                       const DetectionParams& params, DetectionWorkspace& workspace, Detection& detection) {
  if (candidates.empty()) return;
  if (detection.status == DetectionStatus::kRecipeMismatch) {
    detection.recipe_check.best_recipe = best_fitting_recipe(frame, candidates, params, workspace);
    return;
  }
  const bool layer_found =
      detection.layer.status == DetectionStatus::kOk && !detection.layer.polygons.empty();
  if (detection.status != DetectionStatus::kNoLayout || !layer_found) return;
  const std::optional<int> shown = best_fitting_recipe(frame, candidates, params, workspace);
  if (!shown) return;
  detection.status = DetectionStatus::kRecipeMismatch;
  detection.message = "the recipe's formats lay out no layer here (" + detection.message + ") and recipe " +
                      std::to_string(*shown) +
                      "'s lay it out with the sides measured: the layer holds other cartons";
  detection.recipe_check.best_recipe = shown;
}

}  // namespace palletd
