// solve_layout(): the second half of the pipeline on one frame's layer, as three stages: the
// evidence (seam raster, surroundings where the depth ends), the layout search on the outline
// (find_layout, with the outline's tolerance from the layer's pixel pitch) and the refinement.
#include <algorithm>

#include "layer_raster.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

LayoutResult solve_layout(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                          const std::vector<BoxFormat>& formats, const LayoutParams& params) {
  if (layer.status != DetectionStatus::kOk) {
    LayoutResult r;
    r.status = layer.status;
    r.reason = layer.reason;
    return r;
  }
  const SeamEvidence seams = build_seam_evidence(frame, cloud, layer, params.seams);
  double max_long = 0.0;
  for (const auto& f : formats) max_long = std::max(max_long, f.long_m);
  // Only a layer whose outline runs somewhere along pixels without depth or along the image
  // border can have boxes going on unseen.
  const LayerDiagnostics& diag = layer.diagnostics;
  const bool may_go_on = diag.unobserved_outline_fraction > 0.0 || diag.touches_image_border;
  const LayerSurroundings around = params.completion.unseen_min_fraction > 0.0 && may_go_on
                                       ? build_layer_surroundings(frame, cloud, layer, max_long)
                                       : LayerSurroundings{};
  LayoutParams p = params;
  if (p.search.outline_tolerance_m <= 0.0) {
    p.search.outline_tolerance_m = p.search.outline_tolerance_pitches * layout_detail::layer_pixel_pitch_m(frame.intrinsics, layer);
  }
  const LayoutResult found = find_layout(layer.polygons, formats, p, &seams, &around);
  if (!p.refine.enabled || p.search.mode == SearchMode::kPaper) return found;
  const std::vector<RimPixel> rim = build_layer_rim(frame, cloud, layer);
  return refine_layout(found, layer, formats, &seams, p, &around, &rim);
}

}  // namespace palletd
