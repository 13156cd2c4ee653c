// refine_layout(): a joint fit of all boxes of a layout component in its layout frame. Each box
// side is measured where the evidence is: a side on the outline from the box's own layer points
// (walked outward to the first gap), a side shared with a neighbour from the seam raster (the
// box's own edge of the seam band, depth or intensity); every side is a robust line fit
// (refine_joint.cpp). Sides with a neighbour but no visible seam make the two boxes touch; so do
// boxes the fit leaves apart where the layer's points show carton top (rows.cpp), and the boxes
// start spread over their outline's extent (cartons larger than their format, rows.cpp).
// Centres and sizes of all boxes are then one least-squares fit with the nominal format as a
// prior on each size (sizes stay within the tolerance); the per-box yaw follows the fitted
// side slopes. Where an edge lies within the pixel footprint depends on whether the side faces
// the camera (its wall hides the floor behind it) or not: each side's samples are corrected by
// half a footprint accordingly (outline_footprint_correction, seam_footprint_correction); where
// the camera left the mixed pixels straddling an outline edge, their depth places the edge.
#include <algorithm>
#include <cmath>
#include <limits>

#include "evidence/layout_scoring.hpp"
#include "layout_internal.hpp"
#include "refinement/refine_internal.hpp"

namespace palletd {

using namespace layout_detail;

namespace {

/// Layer points are binned in cells of this size for the boxes' neighbourhood queries [m].
constexpr double kGridCell_m = 0.05;
/// How far a box side is looked for beyond where the search put it: cartons run up to 6 % over
/// their format and stand with gaps up to 20 mm that the search packs shut; the search's
/// placement, spread over the outline, leaves the sides of a row of such cartons up to a few
/// centimetres from where they stand [m].
constexpr double kSideWindow_m = 0.06;
constexpr double kSideWindowIn_m = 0.03;

/// The shortest side of the formats (the window stays under half of it) [m].
double smallest_side_m(const std::vector<BoxFormat>& formats) {
  double s = 1.0;
  for (const BoxFormat& f : formats) s = std::min(s, f.short_m);
  return s;
}

/// A box's yaw changes by at most this through the refinement [rad].
const double kMaxYawChange_rad = 5.0 * M_PI / 180.0;

/// The boxes of each component (indices into the layout's boxes).
std::vector<std::vector<std::size_t>> boxes_per_component(const LayoutResult& found, std::size_t components) {
  std::vector<std::vector<std::size_t>> members(components);
  for (std::size_t bi = 0; bi < found.boxes.size(); ++bi) {
    const auto ci = static_cast<std::size_t>(found.boxes[bi].component);
    if (ci < components) members[ci].push_back(bi);
  }
  return members;
}

/// Separate components of one layer stand on the same pallet pattern: each component's
/// orientation deviates from the layer's (weighted mean, mod 90 deg) by its own evidence,
/// shrunk by the prior (a one-box component's outline alone must not turn it by degrees); each
/// refined box turns by that plus its own turn.
void turn_boxes(const std::vector<ComponentFit>& fits, const std::vector<double>& box_turn, double w_prior,
                const LayoutResult& found, LayoutResult& out) {
  double sum_c = 0, sum_s = 0;
  double w_layer = 0.0;  // the layer turn's inverse variance [rad^-2]
  for (const ComponentFit& cf : fits) {
    if (!cf.built) continue;
    const double w = cf.turn_weight + 1e-9;
    sum_c += w * std::cos(4 * cf.turn_rad);
    sum_s += w * std::sin(4 * cf.turn_rad);
    w_layer += cf.turn_weight;
  }
  const double layer_turn = std::atan2(sum_s, sum_c) / 4;
  for (std::size_t bi = 0; bi < out.boxes.size(); ++bi) {
    const auto ci = static_cast<std::size_t>(found.boxes[bi].component);
    if (ci >= fits.size() || !fits[ci].built || !std::isfinite(box_turn[bi])) continue;
    const ComponentFit& cf = fits[ci];
    const double delta = std::remainder(cf.turn_rad - layer_turn, M_PI / 2);
    const double turn = layer_turn + delta * cf.turn_weight / (cf.turn_weight + w_prior);
    const double phi = std::remainder(turn - cf.frame.theta_rad, M_PI / 2) + box_turn[bi];
    if (std::abs(phi) < kMaxYawChange_rad) out.boxes[bi].yaw_rad += phi;
    if (w_layer > 0.0) out.boxes[bi].evidence.yaw_sigma_rad = 1.0 / std::sqrt(w_layer);
  }
}

/// Scores and coverage of the refined boxes.
void rescore(const std::vector<ComponentFit>& fits, const LayoutResult& found, double layer_area_m2,
             const LayoutParams& params, LayoutResult& out) {
  double covered = 0;
  for (std::size_t bi = 0; bi < out.boxes.size(); ++bi) {
    const auto ci = static_cast<std::size_t>(found.boxes[bi].component);
    if (ci >= fits.size() || !fits[ci].built) continue;
    const ComponentFit& cf = fits[ci];
    const BoxSupport s =
        box_support(out.boxes[bi], cf.frame, cf.polygon, cf.table.empty() ? nullptr : &cf.table, params);
    out.boxes[bi].score = s.score;
    set_support_terms(s, out.boxes[bi].evidence);
    covered += s.inside_area_m2;
  }
  if (layer_area_m2 > 0) out.coverage = std::min(1.0, covered / layer_area_m2);
}

}  // namespace

LayoutResult refine_layout(const LayoutResult& found, const LayerResult& layer,
                           const std::vector<BoxFormat>& formats, const SeamEvidence* seams,
                           const LayoutParams& params, const LayerSurroundings* surroundings,
                           const std::vector<RimPixel>* rim) {
  LayoutResult out = found;
  if (found.status != DetectionStatus::kOk || found.boxes.empty()) return out;
  double layer_area = 0;
  for (const auto& p : layer.polygons) layer_area += area(p);
  const PointGrid grid(layer.points_2d, kGridCell_m);
  const bool use_seams = seams != nullptr && !seams->empty() && seams->strength > 0;
  RefineContext ctx{layer, formats, params, use_seams ? seams : nullptr, surroundings, rim, grid};
  ctx.pitch_m =
      layer.points_2d.empty() ? 0.003 : std::sqrt(layer_area / static_cast<double>(layer.points_2d.size()));
  // How far a side may lie from where the search put it (its boxes spread over the outline's
  // extent first: stretch_to_outline): the search packs nominal boxes without gaps, so sides are
  // off by the gaps and size deviations accumulated along a row; less than half the smallest
  // carton side, so that a side is not taken for its neighbour's far one.
  ctx.window_m =
      std::max(std::min(kSideWindow_m, 0.4 * smallest_side_m(formats)), 2.5 * params.seams.margin_m);
  // Inward, a side lies at most by the gaps around it and a carton's shortfall from where the
  // search put it: looking further in takes a label's or a neighbour's seam band for it.
  ctx.window_in_m = std::max(kSideWindowIn_m, 2.5 * params.seams.margin_m);
  // The camera in the layer frame: which box sides face it decides where an edge lies within
  // the pixel footprint (refine_joint.hpp). Unknown (no camera above the plane): no correction.
  ctx.camera_layer = layer.T_camera_layer.inverse().translation();
  ctx.view_known = ctx.camera_layer.z() > 0.1;
  const double yaw_sigma_rad = params.refine.yaw_sigma_deg * M_PI / 180.0;
  const double w_prior = yaw_sigma_rad > 0 ? 1.0 / (yaw_sigma_rad * yaw_sigma_rad) : 1e300;

  std::vector<ComponentFit> fits(layer.polygons.size());
  // Each refined box's own turn against its component (NaN: not refined).
  std::vector<double> box_turn(out.boxes.size(), std::numeric_limits<double>::quiet_NaN());
  const std::vector<std::vector<std::size_t>> members = boxes_per_component(found, layer.polygons.size());
  for (std::size_t ci = 0; ci < members.size(); ++ci) {
    if (members[ci].empty()) continue;
    fits[ci] = fit_component(members[ci], layer.polygons[ci], ctx, w_prior, out.boxes, box_turn);
  }
  turn_boxes(fits, box_turn, w_prior, found, out);
  rescore(fits, found, layer_area, params, out);
  return out;
}

}  // namespace palletd
