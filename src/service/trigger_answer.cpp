// The answer to the PLC's trigger (trigger_answer.hpp).
#include "trigger_answer.hpp"

#include <algorithm>
#include <chrono>

#include "palletd/core/timing.hpp"
#include "palletd/detection/recipe_choice.hpp"

#include "recipe_detection.hpp"
#include "result_record.hpp"

namespace palletd {

TriggerAnswer answer_trigger(const Config& cfg, const Recipe& recipe, const Frame& frame,
                             DetectionWorkspace& workspace) {
  const auto t0 = std::chrono::steady_clock::now();
  TriggerAnswer a;
  a.detection = detect_recipe(cfg, recipe, frame, workspace);
  // Which recipe the frame shows, after a recipe mismatch or a layer the recipe cannot lay out.
  if (a.detection.status == DetectionStatus::kRecipeMismatch ||
      a.detection.status == DetectionStatus::kNoLayout)
    name_recipe_shown(frame, recipe_candidates(cfg, recipe.number), cfg.detection, workspace, a.detection);
  const double elapsed_ms = ms_since(t0);
  a.record = to_result_record(a.detection, frame.T_base_camera.has_value());
  a.record.processing_ms = elapsed_ms;
  if (elapsed_ms > cfg.pipeline.detection_timeout_ms) {
    a.error = modbus::ErrorCode::kDetectionTimeout;
    a.error_text = "detection took " + std::to_string(static_cast<int>(elapsed_ms)) + " ms, over the timeout";
    mark_failed(a.record, a.error, static_cast<std::uint16_t>(std::min(elapsed_ms, 65535.0)));
  } else if (is_failure(a.detection.status)) {
    a.error = modbus::ErrorCode::kDetectionFailed;
    a.error_text = std::string(to_string(a.detection.status)) + ": " + a.detection.message;
  }
  return a;
}

}  // namespace palletd
