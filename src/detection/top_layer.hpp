// detect() in two halves: stages 0-5 (the organized cloud, the region of interest, the top layer)
// and stages 6-9 on a layer found (layout, boxes, health). detect() runs both; the detection of
// unknown cartons finds the layer once and lays it out with every size it tries.
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/layer.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

/// The frame's organized cloud into `workspace` (rays rebuilt when the intrinsics change), the
/// region of interest applied. Returns "" or why the region cannot be applied.
std::string cloud_in_region(const Frame& frame, const DetectionParams& params, DetectionWorkspace& workspace);

/// Stages 1-5 on the workspace's cloud: plane, layer, components, crust contour; 5b: a stereo
/// camera's fattened tops moved back onto the intensity's edges (fattened_edges.hpp). The top level
/// holds at least min_component_box_fraction x the smallest box: a smaller plane above it is no
/// layer.
LayerResult top_layer(const Frame& frame, const OrganizedCloud& cloud, const DetectionParams& params,
                      double smallest_box_m2);

/// A detection that has its layer (and its stage times) and nothing more yet.
Detection with_layer(LayerResult layer, const DetectionParams& params);

/// How a detection ends, whatever its status: stage 9 (the cell's health) for a readable frame,
/// the total time since `t_start`.
struct DetectionEnd {
  using Clock = std::chrono::steady_clock;
  const Frame& frame;
  const DetectionParams& params;
  Clock::time_point t_start;
  bool readable = false;

  Detection operator()(Detection out, DetectionStatus status, std::string message) const;
};

/// Stages 6-9 on `out.layer` (a layer with status ok, the cloud still in `workspace`): an empty
/// level, the layout, the boxes, the recipe check, the picks. `evidence` built for that layer
/// before, or null to build it here.
Detection lay_out_layer(const Frame& frame, const std::vector<BoxFormat>& formats,
                        const DetectionParams& params, DetectionWorkspace& workspace,
                        const LayerEvidence* evidence, Detection out, const DetectionEnd& end);

}  // namespace palletd
