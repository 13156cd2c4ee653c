// Where the intensity image puts the layer's outer edges against where the depth puts them. A
// stereo camera's block matching fattens the tops: a pixel whose matching window straddles an
// edge reports the nearer surface, so the depth outline lies a pixel or more outside the edge;
// its infrared image, which depth is registered to, is not matched and shows the edge where it
// is. A time-of-flight camera measures depth and amplitude in the same pixel: the two agree.
#pragma once

#include <cstddef>

#include "palletd/core/frame.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd {

struct EdgeOffset {
  /// Median over the outline samples: how far inside the depth outline the intensity's edge lies
  /// [m] (negative: outside).
  double offset_m = 0.0;
  std::size_t samples = 0;  ///< outline samples with a clear intensity step; 0: no estimate
  /// The offset as it changes with the side's facing, offset = inset_m + shift_m . n for a side
  /// whose outward normal is n (layer frame): the outline moved in by inset_m everywhere and
  /// translated by -shift_m. A camera that looks at the layer from one side sees the walls below
  /// the sides that face it, and the matching window fattens those tops less than the sides
  /// that hide the floor behind them. Without sides seen both ways: offset_m and no shift.
  double inset_m = 0.0;
  Eigen::Vector2d shift_m = Eigen::Vector2d::Zero();
};

/// The layer's outer rings sampled a pixel pitch apart (away from the corners), the intensity
/// read across each sample over four pixels either side; where it steps clearly, the step's
/// position. No estimate without intensity or with fewer than `min_samples` clear steps; no
/// change with the facing unless `min_samples` face the camera and as many face away from it.
EdgeOffset intensity_edge_offset(const Frame& frame, const LayerResult& layer, std::size_t min_samples = 20);

}  // namespace palletd
