// best_fitting_recipe(): the configured recipe whose cartons the frame shows.
#include "palletd/detection/recipe_choice.hpp"

namespace palletd {

std::optional<int> best_fitting_recipe(const Frame& frame, const std::vector<RecipeCandidate>& candidates,
                                       const DetectionParams& params, DetectionWorkspace& workspace) {
  std::optional<int> best;
  double best_confidence = -1.0;
  for (const RecipeCandidate& c : candidates) {
    const Detection d = detect(frame, c.formats, params, workspace);
    if (d.status != DetectionStatus::kOk || d.boxes.empty() || !d.recipe_check.agrees) continue;
    if (d.layout_confidence > best_confidence) {
      best_confidence = d.layout_confidence;
      best = c.number;
    }
  }
  return best;
}

}  // namespace palletd
