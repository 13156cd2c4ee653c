// palletd results: the overlay picture a commissioning engineer looks at: the depth image in a
// colour map with the region of interest's edges, the detected layer outline and the numbered
// boxes (pick order) drawn over it.
#pragma once

#include <cstdint>
#include <vector>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/pick_check.hpp"
#include "palletd/core/frame.hpp"

namespace palletd {

/// The overlay as an encoded PNG (8-bit colour). Small frames are scaled up so the numbers stay
/// legible. Never fails on a frame that detect() accepted; returns an empty vector otherwise.
/// With `check` (the result answers a pick check), the checked boxes are drawn too: a box the pick
/// took crossed out in grey, one still standing (missed pick) in red with "missed", a box gone that
/// was not picked crossed out in red, a box that moved in cyan with how far.
std::vector<std::uint8_t> render_overlay_png(const Frame& frame, const Detection& detection,
                                             const PickCheck* check = nullptr);

}  // namespace palletd
