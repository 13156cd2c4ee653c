// detect_unknown_cartons(): a layer of cartons whose size only a range bounds. The layer and its
// seam evidence are found once; the candidate sizes come from its outline and seams
// (candidate_sizes()) and each one is laid out on it (stages 6-9 of detect()); the size whose
// layout the frame supports best and whose boxes measure as that size wins, and is laid out again
// with the size measured on its boxes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "palletd/core/statistics.hpp"
#include "palletd/detection/confidence.hpp"
#include "palletd/detection/recipe_check.hpp"
#include "palletd/detection/unknown_cartons.hpp"

#include "edge_offset.hpp"
#include "frame_problem.hpp"
#include "layer_raster.hpp"
#include "seam_agreement.hpp"
#include "top_layer.hpp"

namespace palletd {

namespace {

using Clock = std::chrono::steady_clock;

/// Spread of a carton's measured side around the size it was laid out with [m]: the candidates'
/// sizes come from seam spacings a few millimetres off, and their boxes measured off by that much
/// lose little; a size the boxes do not show at all loses.
constexpr double kUnknownSizeSigma_m = 0.02;

struct Trial {
  BoxFormat tried;
  Detection detection;
  BoxFormat measured;  ///< median measured sides; the candidate's own where none were measured
  double fit = 0.0;    ///< evidence() x agreement of the measured sides with the size tried
  SeamAgreement::Score seams;  ///< seams along the boxes' sides, none across (0 without a layout)
  /// Boxes carrying their cartons' tape across their middle (taped_across_unmeasured()).
  int taped_across = 0;

  [[nodiscard]] double evidence() const { return seams.product(); }
  /// The tape says the size is half a carton laid the other way.
  [[nodiscard]] bool half_carton(const RecipeCheckParams& check) const {
    return check.taped_across(taped_across);
  }
};

/// One layer of the frame and what the layout stage reads about it, laid out with every size tried.
struct SharedLayer {
  const Frame& frame;
  const LayerResult& layer;
  const LayerEvidence& evidence;
  DetectionWorkspace& workspace;  ///< holds the frame's organized cloud

  [[nodiscard]] Detection lay_out(const BoxFormat& size, const DetectionParams& params) const {
    const DetectionEnd end{frame, params, Clock::now(), true};
    return lay_out_layer(frame, {size}, params, workspace, &evidence, with_layer(layer, params), end);
  }
};

/// The candidate laid out; its boxes' measured sides against it.
Trial try_size(const SharedLayer& shared, const BoxFormat& size, const DetectionParams& params,
               const SeamAgreement& agreement) {
  Trial t{size, shared.lay_out(size, params), size, 0.0, {}};
  if (t.detection.status != DetectionStatus::kOk || t.detection.boxes.empty()) return t;
  std::vector<double> longs, shorts;
  for (const DetectedBox& b : t.detection.boxes) {
    if (b.measured_long_m > 0.0) longs.push_back(b.measured_long_m);
    if (b.measured_short_m > 0.0) shorts.push_back(b.measured_short_m);
  }
  double z2 = 0.0;
  for (auto [sides, nominal, measured] : {std::tuple(&longs, size.long_m, &t.measured.long_m),
                                          std::tuple(&shorts, size.short_m, &t.measured.short_m)}) {
    const double m = upper_median(*sides, -1.0);
    const double z = m > 0.0 ? (m - nominal) / kUnknownSizeSigma_m : 0.4;  // unmeasured: 8 mm off
    if (m > 0.0) *measured = m;
    z2 += z * z;
  }
  if (t.measured.short_m > t.measured.long_m) std::swap(t.measured.long_m, t.measured.short_m);
  t.seams = agreement.score(t.detection.boxes);
  t.taped_across = static_cast<int>(
      std::count_if(t.detection.boxes.begin(), t.detection.boxes.end(), taped_across_unmeasured));
  // A size that leaves part of the layer bare (cartons too large to fit where the others do) is
  // weighed by its coverage once more: the seams it explains cover less of the layer.
  t.fit = t.evidence() * t.detection.coverage * std::exp(-0.25 * z2);
  return t;
}

bool same_size(const BoxFormat& a, const BoxFormat& b) {
  return std::abs(a.long_m - b.long_m) < 0.015 && std::abs(a.short_m - b.short_m) < 0.015;
}

/// Cartons of half the size along either side, or two side by side (a 5 mm gap between), within
/// the range.
std::vector<BoxFormat> halves_and_doubles(const BoxFormat& f, const SizeRange& range) {
  constexpr double kGap_m = 0.005;
  const double l = f.long_m, s = f.short_m;
  std::vector<BoxFormat> out;
  for (auto [a, b] : {std::pair((l - kGap_m) / 2, s), std::pair(l, (s - kGap_m) / 2),
                      std::pair(2 * l + kGap_m, s), std::pair(l, 2 * s + kGap_m)}) {
    const double long_m = std::max(a, b), short_m = std::min(a, b);
    if (range.admits(long_m, short_m)) out.push_back({long_m, short_m, "", 0.0});
  }
  return out;
}

std::string mm(const BoxFormat& f) {
  return std::to_string(static_cast<int>(std::lround(1e3 * f.long_m))) + " x " +
         std::to_string(static_cast<int>(std::lround(1e3 * f.short_m))) + " mm";
}

std::string range_problem(const SizeRange& r) {
  if (!(r.long_min_m > 0.0 && r.short_min_m > 0.0 && r.long_min_m <= r.long_max_m &&
        r.short_min_m <= r.short_max_m))
    return "the size range is empty or not positive: check size_range_mm (long and short, [min, max] in "
           "millimetres)";
  return {};
}

/// Each candidate laid out, then the best one's halves and doubles (two cartons side by side look
/// like one where no seam shows: such a tie is then seen, not decided by which sizes were
/// proposed); sorted by fit, best first, behind every other a size whose boxes carry their
/// cartons' tape across (half a carton). `without_boxes` keeps an empty pallet or a slip sheet.
std::vector<Trial> try_sizes(const SharedLayer& shared, const std::vector<SizeCandidate>& candidates,
                             const SizeRange& range, const DetectionParams& params,
                             const SeamAgreement& agreement, std::optional<Detection>& without_boxes) {
  std::vector<Trial> trials;
  for (const SizeCandidate& c : candidates) {
    Trial t = try_size(shared, c.format, params, agreement);
    if (t.detection.status == DetectionStatus::kEmpty || t.detection.status == DetectionStatus::kSlipSheet)
      without_boxes = t.detection;
    if (t.evidence() > 0.0) trials.push_back(std::move(t));
  }
  std::sort(trials.begin(), trials.end(), [](const Trial& a, const Trial& b) { return a.fit > b.fit; });
  if (trials.empty()) return trials;
  for (const BoxFormat& f : halves_and_doubles(trials.front().measured, range)) {
    const bool tried =
        std::any_of(trials.begin(), trials.end(), [&](const Trial& t) { return same_size(t.tried, f); });
    if (tried) continue;
    Trial t = try_size(shared, f, params, agreement);
    if (t.evidence() > 0.0) trials.push_back(std::move(t));
  }
  const RecipeCheckParams& check = params.recipe_check;
  std::stable_sort(trials.begin(), trials.end(), [&check](const Trial& a, const Trial& b) {
    const bool half_a = a.half_carton(check), half_b = b.half_carton(check);
    return half_a != half_b ? half_b : a.fit > b.fit;
  });
  return trials;
}

/// Cartons smaller than the best's (more boxes) whose sides run along seams the best size leaves
/// across its boxes' tops, and that still show seams along a fair part of their sides: where the
/// other gaps are too narrow to show, the frame cannot tell two cartons from the one the best size
/// makes of them. (Halves of the right carton explain no more seams than it does.)
bool finer_fits_as_well(const Trial& other, const Trial& best) {
  if (other.detection.boxes.size() <= best.detection.boxes.size()) return false;
  return other.seams.explained >= best.seams.explained + 0.03 && other.seams.shown >= 0.3 * best.seams.shown;
}

/// Why the best size is in doubt, "" when it is not: the frame shows too few seams to tell one
/// carton from two, its boxes carry their cartons' tape across (every size tried does), or
/// another size is supported nearly as well (one whose boxes carry the tape across too: a layer
/// may hold cartons of two sizes).
std::string size_doubt(const std::vector<Trial>& trials, const UnknownCartonParams& unknown,
                       const RecipeCheckParams& check) {
  const Trial& best = trials.front();
  if (best.half_carton(check)) {
    return "the cartons' tape runs across the middle of " + std::to_string(best.taped_across) + " boxes of " +
           mm(best.measured) + ": each may be half a carton laid the other way";
  }
  if (best.evidence() < unknown.min_evidence && best.detection.boxes.size() > 1)
    return "the seams between the cartons are not seen (evidence " +
           std::to_string(best.evidence()).substr(0, 4) + "): one carton cannot be told from two";
  const ScoreTerms& camera = best.detection.boxes.front().score_terms;
  if (best.detection.boxes.size() > 1 &&
      (camera.pitch_mm > unknown.max_pitch_mm || camera.rim_share < unknown.min_rim_share))
    return "the camera does not show narrow seams here (pixel pitch " +
           std::to_string(static_cast<int>(std::lround(camera.pitch_mm))) + " mm, mixed pixels along " +
           std::to_string(static_cast<int>(std::lround(100.0 * camera.rim_share))) +
           " % of the outline): one carton cannot be told from two";
  if (best.detection.coverage < unknown.min_coverage)
    return "cartons of " + mm(best.measured) + " leave " +
           std::to_string(static_cast<int>(std::lround(100.0 * (1.0 - best.detection.coverage)))) +
           " % of the layer bare: cartons of another size may stand there";
  for (std::size_t i = 1; i < trials.size(); ++i) {
    const BoxFormat& other = trials[i].measured;
    if (same_size(other, best.measured)) continue;
    if (trials[i].evidence() < unknown.tie_ratio * best.evidence() && !finer_fits_as_well(trials[i], best))
      continue;
    return "cartons of " + mm(other) + " explain the layer nearly as well as " + mm(best.measured);
  }
  return {};
}

/// Why the sizes measured on the outline are in doubt, "" when they are not: the depth's edges lie
/// outside the intensity's by more than max_edge_offset_px (a stereo camera's fattened tops).
std::string fattened_tops(const EdgeOffset& edges, const Intrinsics& intrinsics, const LayerResult& layer,
                          const UnknownCartonParams& unknown) {
  const double pitch_m = layout_detail::layer_pixel_pitch_m(intrinsics, layer);
  if (edges.samples == 0 || !(edges.offset_m > unknown.max_edge_offset_px * pitch_m)) return {};
  const auto offset_mm = static_cast<int>(std::lround(1e3 * edges.offset_m));
  return "the depth's edges lie " + std::to_string(offset_mm) +
         " mm outside the intensity image's (the camera fattens the tops): sizes measured on the "
         "outline run up to " +
         std::to_string(2 * offset_mm) + " mm large";
}

/// The carton size is in doubt: the layout is flagged and its confidences say so.
void flag_size_doubt(const std::string& why, Detection& out) {
  out.ambiguous = true;
  out.ambiguity_reason += (out.ambiguity_reason.empty() ? "" : "; ") + why;
  out.ambiguity_kinds.push_back(AmbiguityKind::kTiedLayouts);
  for (DetectedBox& b : out.boxes) {
    b.score_terms.layout_ambiguous = true;
    b.score = box_confidence(b.score_terms);
  }
  out.layout_confidence = layout_confidence(out);
}

/// A frame that ends before a size is tried: no_layout (or bad_frame) with the layer for overlays.
Detection without_layout(DetectionStatus status, std::string message, LayerResult layer) {
  Detection d;
  d.status = status;
  d.message = std::move(message);
  d.layer = std::move(layer);
  d.plane_camera = d.layer.plane_camera;
  d.formats_measured = true;
  return d;
}

}  // namespace

Detection detect_unknown_cartons(const Frame& frame, const SizeRange& range, const DetectionParams& params,
                                 DetectionWorkspace& workspace, const UnknownCartonParams& unknown) {
  const auto t_start = Clock::now();
  if (std::string problem = frame_problem(frame); !problem.empty())
    return without_layout(DetectionStatus::kBadFrame, problem, {});
  if (std::string problem = range_problem(range); !problem.empty())
    return without_layout(DetectionStatus::kNoLayout, problem, {});
  const BoxFormat smallest{range.long_min_m, range.short_min_m, "smallest", 0.0};
  if (std::string problem = cloud_in_region(frame, params, workspace); !problem.empty())
    return without_layout(DetectionStatus::kBadFrame, problem, {});
  LayerResult layer = top_layer(frame, workspace.cloud, params, smallest.long_m * smallest.short_m);
  if (layer.status != DetectionStatus::kOk) {  // detect() names the failure (no plane, empty pallet, ...)
    Detection d = detect(frame, {smallest}, params, workspace);
    d.formats_measured = true;
    return d;
  }
  LayerEvidence evidence = build_layer_evidence(frame, workspace.cloud, layer, params.layout.seams);
  if (completes_unseen(layer, params.layout.completion)) {
    evidence.around = build_layer_surroundings(frame, workspace.cloud, layer, range.long_max_m);
    evidence.around_reach_m = range.long_max_m;
  }
  const std::vector<SizeCandidate> candidates = candidate_sizes(layer, evidence.seams, range, unknown);
  const SharedLayer shared{frame, layer, evidence, workspace};

  DetectionParams trial_params = params;  // the size is the question: no recipe check, no picks
  trial_params.recipe_check.enabled = false;
  trial_params.gripper.reset();
  std::optional<Detection> without_boxes;  // an empty pallet or a slip sheet, whatever the size
  const SeamAgreement agreement(layer, evidence.seams, unknown.outline_margin_m);
  std::vector<Trial> trials = try_sizes(shared, candidates, range, trial_params, agreement, without_boxes);
  // A sheet over the layer shows no seams whatever the size: where some size called it a sheet
  // and the size that fits best (tape or not) finds no seams, no boxes are reported.
  const auto best_fit = std::max_element(trials.begin(), trials.end(),
                                         [](const Trial& a, const Trial& b) { return a.fit < b.fit; });
  const bool sheet_likely = without_boxes && (trials.empty() || best_fit->evidence() < unknown.min_evidence);
  if (trials.empty() || sheet_likely) {
    if (without_boxes) {
      without_boxes->formats_measured = true;
      return *without_boxes;
    }
    return without_layout(DetectionStatus::kNoLayout,
                          "no carton size within the size range lays out the layer (" +
                              std::to_string(candidates.size()) + " sizes tried)",
                          std::move(layer));
  }
  const Trial& best = trials.front();

  // The winner again with the size its boxes measure (a recipe check would compare the size with
  // itself) and the picks on.
  DetectionParams final_params = params;
  final_params.recipe_check.enabled = false;
  Detection out = shared.lay_out(best.measured, final_params);
  if (out.status != DetectionStatus::kOk || out.boxes.empty() ||
      out.layout_confidence < 0.8 * best.detection.layout_confidence)
    out = shared.lay_out(best.tried, final_params);
  const std::string doubt = size_doubt(trials, unknown, params.recipe_check);
  if (!doubt.empty()) flag_size_doubt(doubt, out);
  const std::string fattened =
      fattened_tops(intensity_edge_offset(frame, layer), frame.intrinsics, layer, unknown);
  if (!fattened.empty()) flag_size_doubt(fattened, out);
  for (DetectedBox& b : out.boxes) b.format = -1;
  out.formats_measured = true;
  out.timing_ms["total"] = std::chrono::duration<double, std::milli>(Clock::now() - t_start).count();
  out.timing_ms["sizes_tried"] = static_cast<double>(candidates.size());
  return out;
}

}  // namespace palletd
