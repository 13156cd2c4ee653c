// Stages 0-5 of detect() on their own: the organized cloud, the region of interest, the top
// layer. detect() and the detection of unknown cartons share them.
#pragma once

#include <string>

#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd {

/// The frame's organized cloud into `workspace` (rays rebuilt when the intrinsics change), the
/// region of interest applied. Returns "" or why the region cannot be applied.
std::string cloud_in_region(const Frame& frame, const DetectionParams& params, DetectionWorkspace& workspace);

/// Stages 1-5 on the workspace's cloud: plane, layer, components, crust contour. The top level
/// holds at least min_component_box_fraction x the smallest box: a smaller plane above it is no
/// layer.
LayerResult top_layer(const Frame& frame, const OrganizedCloud& cloud, const DetectionParams& params,
                      double smallest_box_m2);

}  // namespace palletd
