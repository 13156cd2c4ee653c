// Debug pictures of the layer extraction, one per stage (palletctl detect --debug-dir writes them).
// Rendering only: detection never writes files.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "palletd/core/frame.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd {

/// One 8UC3 image per stage, named "layer_mask", "border_points", "crust_graph", "rings", each
/// the frame's size drawn over the depth image: the cleaned layer mask, the border points, the
/// Delaunay graph after pruning, the final polygons (outer green, holes red, corners yellow).
/// `trace` is the one filled by extract_layer(); empty stages give plain depth images.
std::vector<std::pair<std::string, cv::Mat>> render_layer_debug_images(const Frame& frame,
                                                                       const LayerResult& result,
                                                                       const LayerTrace& trace);

}  // namespace palletd
