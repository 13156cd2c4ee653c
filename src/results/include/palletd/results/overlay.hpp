// palletd results: the overlay picture a commissioning engineer looks at: the depth image in a
// colour map with the region of interest's edges, the detected layer outline and the numbered
// boxes (pick order) drawn over it.
#pragma once

#include <cstdint>
#include <vector>

#include "palletd/detection/detection.hpp"
#include "palletd/core/frame.hpp"

namespace palletd {

/// The overlay as an encoded PNG (8-bit colour). Small frames are scaled up so the numbers stay
/// legible. Never fails on a frame that detect() accepted; returns an empty vector otherwise.
std::vector<std::uint8_t> render_overlay_png(const Frame& frame, const Detection& detection);

}  // namespace palletd
