// palletd service (private): a recipe's detection on a frame, as a trigger, the shadow
// configuration and the start-up warm-up run it.
#pragma once

#include "palletd/config/config.hpp"
#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"

#include "acquisition.hpp"

namespace palletd {

/// The configured recipe with this number; null when there is none.
const Recipe* find_recipe(const Config& config, int number);

/// The config's camera_to_base, when it gives one, replaces the frame's own (a recording's or a
/// driver's): every detection, check and drift reference of the service is in the config's base.
void apply_calibration(const Config& config, Frame& frame);

/// detect() with the recipe's formats, or detect_unknown_cartons() when it gives a size range.
Detection detect_recipe(const Config& config, const Recipe& recipe, const Frame& frame,
                        DetectionWorkspace& workspace);

/// The process's first detection allocates the viewing rays, the cloud and the search's buffers
/// (40-50 ms more at 640 x 480): one detection of the default recipe on the camera's next frame,
/// its result discarded, pays that before the PLC's first trigger. Returns its time [ms], or -1
/// when there is no default recipe or no frame comes within the frame timeout. Exceptions are
/// the caller's (the pipeline thread's top).
double warm_up(Acquisition& acquisition, const Config& config, DetectionWorkspace& workspace);

}  // namespace palletd
