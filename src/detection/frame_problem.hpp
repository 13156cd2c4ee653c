// Whether a frame can be worked on at all: size, intrinsics, depth image, depth scale. Used by
// detect(), measure_drift() and check_pick() before they touch a pixel.
#pragma once

#include <string>

#include "palletd/core/frame.hpp"

namespace palletd {

/// Why the frame cannot be worked on, in a sentence; "" when it can.
std::string frame_problem(const Frame& frame);

}  // namespace palletd
