// solve_layout(): the second half of the pipeline on one frame's layer, as three stages: the
// evidence (seam raster, surroundings where the depth ends), the layout search on the outline
// (find_layout, with the outline's tolerance from the layer's pixel pitch) and the refinement.
#include <algorithm>
#include <cmath>

#include "layer_raster.hpp"
#include "layout_internal.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

namespace {

/// Marks the boxes of the runner-up's component that the runner-up does not have: its boxes
/// are where the search put them, so a box counts as shared within a quarter of its short side,
/// 1 cm of size and 5 deg of yaw.
void mark_contested(LayoutResult& result) {
  if (result.runner_up.empty()) return;
  for (LayoutBox& b : result.boxes) {
    if (b.component != result.runner_up_component) continue;
    const bool shared = std::any_of(result.runner_up.begin(), result.runner_up.end(), [&](const Box2d& r) {
      return (r.center - b.center).norm() < 0.25 * b.short_m && std::abs(r.long_m - b.long_m) < 0.01 &&
             std::abs(r.short_m - b.short_m) < 0.01 &&
             std::abs(std::remainder(r.yaw_rad - b.yaw_rad, M_PI)) < 5.0 * M_PI / 180.0;
    });
    b.evidence.contested = !shared;
  }
}

}  // namespace

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
  LayoutResult result = find_layout(layer.polygons, formats, p, &seams, &around);
  const std::vector<RimPixel> rim = build_layer_rim(frame, cloud, layer);
  if (p.refine.enabled && p.search.mode != SearchMode::kPaper) {
    result = refine_layout(result, layer, formats, &seams, p, &around, &rim);
  }
  mark_contested(result);
  result.interior_seams = measure_interior_seams(result.boxes, seams, layer.polygons);
  result.pixel_pitch_m = layout_detail::layer_pixel_pitch_m(frame.intrinsics, layer);
  double outline_m = 0.0;
  for (const PolygonWithHoles& polygon : layer.polygons) outline_m += layout_detail::rings_length_m(polygon);
  if (outline_m > 0.0) result.rim_share = static_cast<double>(rim.size()) * result.pixel_pitch_m / outline_m;
  return result;
}

}  // namespace palletd
