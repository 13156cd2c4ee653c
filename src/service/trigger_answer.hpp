// The answer to the PLC's trigger: the recipe's detection on the frame after it, as the result
// block reports it (a detection over the timeout is a failed trigger, its layout withheld).
#pragma once

#include <string>

#include "palletd/config/config.hpp"
#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/modbus/register_map.hpp"

namespace palletd {

struct TriggerAnswer {
  Detection detection;
  modbus::ResultRecord record;  ///< status kFailed with kDetectionTimeout when it ran too long
  modbus::ErrorCode error = modbus::ErrorCode::kNone;
  std::string error_text;  ///< "" when the detection answered
};

/// detect_recipe() on `frame`; where the layer does not agree with the recipe, the configured
/// recipe it fits best is named in the result.
TriggerAnswer answer_trigger(const Config& cfg, const Recipe& recipe, const Frame& frame,
                             DetectionWorkspace& workspace);

}  // namespace palletd
