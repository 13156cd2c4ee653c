// Stage 5b: a stereo camera's fattened tops moved back onto the edges its intensity image shows
// (edge_offset.hpp says why the two differ on a stereo camera and agree on a time-of-flight one).
#pragma once

#include "palletd/core/frame.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd {

/// The layer with its outline moved in by the intensity's edge offset when that lies between
/// params.fattened_edge_min_px and fattened_edge_max_px pixel pitches (holes grow by as much),
/// and the layer points beyond the new outline dropped; otherwise unchanged. Either way the
/// offset measured and the distance moved are in the diagnostics.
LayerResult trim_fattened_edges(const Frame& frame, LayerResult layer, const LayerParams& params);

}  // namespace palletd
