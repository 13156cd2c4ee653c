// solve_layout(): the second half of the pipeline on one frame's layer, as three stages: the
// evidence (seam raster, surroundings where the depth ends), the layout search on the outline
// (find_layout, with the outline's tolerance from the layer's pixel pitch) and the refinement.
#include <algorithm>
#include <cmath>

#include "palletd/detection/layout.hpp"

#include "evidence/layout_scoring.hpp"
#include "evidence/tape.hpp"
#include "layer_raster.hpp"
#include "layout_internal.hpp"

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

/// Tolerance of "the same size" between a box and two boxes of another format [m].
constexpr double kSameSize_m = 0.012;

/// The recipe format of this size (within kSameSize_m), or -1.
int format_of_size(const std::vector<BoxFormat>& formats, double long_m, double short_m) {
  for (std::size_t f = 0; f < formats.size(); ++f) {
    if (std::abs(formats[f].long_m - long_m) < kSameSize_m &&
        std::abs(formats[f].short_m - short_m) < kSameSize_m)
      return static_cast<int>(f);
  }
  return -1;
}

/// Marks boxes whose place another format could take by two (split_seam), or a pair that one box
/// of another format could replace (join_seam), with the strongest seam across that box or pair:
/// where the camera does not show narrow seams, nothing else tells the two apart; where it does,
/// a pair without a seam between is one carton (level_checks.cpp).
void mark_format_doubt(const std::vector<PolygonWithHoles>& components, const std::vector<BoxFormat>& formats,
                       const SeamEvidence& seams, const LayoutParams& params, LayoutResult& result) {
  // Per format: the format two of it make, and whether two of another format make it.
  std::vector<int> doubled(formats.size(), -1);
  std::vector<bool> splits(formats.size(), false);
  for (std::size_t f = 0; f < formats.size(); ++f) {
    doubled[f] = doubled_format(formats, formats[f]);
    if (doubled[f] >= 0) splits[static_cast<std::size_t>(doubled[f])] = true;
  }
  std::vector<LayoutBox>& boxes = result.boxes;
  for (LayoutBox& b : boxes) {
    const auto fa = static_cast<std::size_t>(b.format);
    if (fa >= formats.size() || b.component < 0 || static_cast<std::size_t>(b.component) >= components.size()) continue;
    // A band of tape along a box's middle is its own carton's: two cartons of another format
    // would carry theirs across it.
    const bool own_tape = (splits[fa] || doubled[fa] >= 0) && layout_detail::taped(b, seams);
    if (splits[fa] && !own_tape) b.evidence.split_seam = b.evidence.interior_seam;
    if (doubled[fa] < 0 || own_tape) continue;
    const BoxFormat& pair_format = formats[static_cast<std::size_t>(doubled[fa])];
    const Eigen::Vector2d axis(std::cos(b.yaw_rad), std::sin(b.yaw_rad));
    for (const LayoutBox& n : boxes) {  // a neighbour across its long side, of its format, in line
      if (&n == &b || n.format != b.format || n.component != b.component) continue;
      const Eigen::Vector2d d = n.center - b.center;
      if (std::abs(std::remainder(n.yaw_rad - b.yaw_rad, M_PI)) > 3.0 * M_PI / 180.0) continue;
      if (std::abs(d.dot(axis)) > kSameSize_m || std::abs(std::abs(d.x() * axis.y() - d.y() * axis.x()) - formats[fa].short_m) > 0.025)
        continue;
      if (layout_detail::taped(n, seams)) continue;
      Box2d pair = b;
      pair.center = 0.5 * (b.center + n.center);
      pair.yaw_rad = b.yaw_rad + M_PI / 2;
      pair.long_m = pair_format.long_m;
      pair.short_m = pair_format.short_m;
      pair.format = doubled[fa];
      const double seam =
          layout_detail::box_support(pair, components[static_cast<std::size_t>(b.component)], &seams, params)
              .interior_seam;
      b.evidence.join_seam = b.evidence.join_seam < 0 ? seam : std::min(b.evidence.join_seam, seam);
    }
  }
}

/// The box of b's format, turned as b, standing at `offset_box` from b (b's frame: along its long
/// side, across it) within the widest gap between cartons, or null.
const LayoutBox* neighbour_at(const std::vector<LayoutBox>& boxes, const LayoutBox& b,
                              const Eigen::Vector2d& offset_box) {
  const Eigen::Vector2d want = b.center + Eigen::Rotation2Dd(b.yaw_rad) * offset_box;
  for (const LayoutBox& n : boxes) {
    if (&n == &b || n.format != b.format || n.component != b.component) continue;
    if (std::abs(std::remainder(n.yaw_rad - b.yaw_rad, M_PI)) > 3.0 * M_PI / 180.0) continue;
    if ((n.center - want).norm() < kMaxCartonGap_m + 0.005) return &n;
  }
  return nullptr;
}

/// Four boxes of one format two by two whose block is another recipe format's footprint (four
/// 300 x 200 make a 600 x 400): the pairs along their long sides make a third format (400 x 300),
/// which mark_format_doubt weighs, but the line between those pairs, across the block's middle,
/// is weighed by no pair. With no seam along it the block could as well be one carton: each box
/// keeps the weaker seam as its join_seam.
void mark_block_doubt(const std::vector<BoxFormat>& formats, const SeamEvidence& seams,
                      const LayoutParams& params, LayoutResult& result) {
  constexpr double kLineReach_m = 0.015;  // the line's place: half the widest gap and a pose error
  for (LayoutBox& b : result.boxes) {
    const auto fa = static_cast<std::size_t>(b.format);
    if (fa >= formats.size()) continue;
    const BoxFormat& f = formats[fa];
    const int block = format_of_size(formats, 2.0 * f.long_m, 2.0 * f.short_m);  // four two by two
    if (block < 0) continue;
    for (const double along : {-1.0, 1.0}) {
      const LayoutBox* n1 = neighbour_at(result.boxes, b, {along * f.long_m, 0.0});
      for (const double across : {-1.0, 1.0}) {
        const LayoutBox* n2 = neighbour_at(result.boxes, b, {0.0, across * f.short_m});
        const LayoutBox* n3 = neighbour_at(result.boxes, b, {along * f.long_m, across * f.short_m});
        if (n1 == nullptr || n2 == nullptr || n3 == nullptr) continue;
        Box2d whole = b;
        whole.center = 0.25 * (b.center + n1->center + n2->center + n3->center);
        whole.long_m = formats[static_cast<std::size_t>(block)].long_m;
        whole.short_m = formats[static_cast<std::size_t>(block)].short_m;
        whole.format = block;
        const double seam = layout_detail::seam_across_middle(whole, &seams, params, kLineReach_m);
        b.evidence.join_seam = b.evidence.join_seam < 0 ? seam : std::min(b.evidence.join_seam, seam);
      }
    }
  }
}

/// Marks the boxes with a band of tape across their middle and none along it (tape_across), and
/// those with a band across each of their halves (tape_halves). Near-square boxes are left out of
/// the first: which way their flaps close says little about their turn.
void mark_tape_across(const SeamEvidence& seams, LayoutResult& result) {
  constexpr double kMinAspect = 1.15;  // long over short side of a box whose tape tells its way round
  if (seams.tops.empty()) return;
  for (LayoutBox& b : result.boxes) {
    b.evidence.tape_halves = layout_detail::taped_in_halves(b, seams);
    if (b.long_m < kMinAspect * b.short_m) continue;
    b.evidence.tape_across = layout_detail::taped(b, seams, true) && !layout_detail::taped(b, seams);
  }
}

/// No layout without a layer: its status and reason.
LayoutResult without_layer(const LayerResult& layer) {
  LayoutResult r;
  r.status = layer.status;
  r.reason = layer.reason;
  return r;
}

}  // namespace

int doubled_format(const std::vector<BoxFormat>& formats, const BoxFormat& half) {
  return format_of_size(formats, 2.0 * half.short_m, half.long_m);
}

int halved_format(const std::vector<BoxFormat>& formats, const BoxFormat& whole) {
  return format_of_size(formats, whole.short_m, 0.5 * whole.long_m);
}

LayerEvidence build_layer_evidence(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                                   const SeamParams& params) {
  return {build_seam_evidence(frame, cloud, layer, params), build_layer_rim(frame, cloud, layer), {}, 0.0};
}

bool completes_unseen(const LayerResult& layer, const CompletionParams& params) {
  const LayerDiagnostics& diag = layer.diagnostics;
  return params.unseen_min_fraction > 0.0 &&
         (diag.unobserved_outline_fraction > 0.0 || diag.touches_image_border);
}

LayoutResult solve_layout(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                          const std::vector<BoxFormat>& formats, const LayoutParams& params,
                          SearchMemory* memory) {
  if (layer.status != DetectionStatus::kOk) return without_layer(layer);
  return solve_layout(frame, cloud, layer, build_layer_evidence(frame, cloud, layer, params.seams), formats,
                      params, memory);
}

LayoutResult solve_layout(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                          const LayerEvidence& evidence, const std::vector<BoxFormat>& formats,
                          const LayoutParams& params, SearchMemory* memory) {
  if (layer.status != DetectionStatus::kOk) return without_layer(layer);
  const SeamEvidence& seams = evidence.seams;
  double max_long = 0.0;
  for (const auto& f : formats) max_long = std::max(max_long, f.long_m);
  const bool completes = completes_unseen(layer, params.completion);
  const bool shared = completes && evidence.around_reach_m >= max_long;
  const LayerSurroundings own =
      completes && !shared ? build_layer_surroundings(frame, cloud, layer, max_long) : LayerSurroundings{};
  const LayerSurroundings& around = shared ? evidence.around : own;
  LayoutParams p = params;
  if (p.search.outline_tolerance_m <= 0.0) {
    p.search.outline_tolerance_m = p.search.outline_tolerance_pitches * layout_detail::layer_pixel_pitch_m(frame.intrinsics, layer);
  }
  LayoutResult result = find_layout(layer.polygons, formats, p, &seams, &around, memory);
  const std::vector<RimPixel>& rim = evidence.rim;
  if (p.refine.enabled && p.search.mode != SearchMode::kPaper) {
    result = refine_layout(result, layer, formats, &seams, p, &around, &rim);
  }
  mark_contested(result);
  if (formats.size() > 1) {
    mark_format_doubt(layer.polygons, formats, seams, p, result);
    mark_block_doubt(formats, seams, p, result);
  }
  result.interior_seams = measure_interior_seams(result.boxes, seams, layer.polygons);
  mark_tape_across(seams, result);
  result.pixel_pitch_m = layout_detail::layer_pixel_pitch_m(frame.intrinsics, layer);
  double outline_m = 0.0;
  for (const PolygonWithHoles& polygon : layer.polygons) outline_m += layout_detail::rings_length_m(polygon);
  if (outline_m > 0.0) result.rim_share = static_cast<double>(rim.size()) * result.pixel_pitch_m / outline_m;
  return result;
}

}  // namespace palletd
