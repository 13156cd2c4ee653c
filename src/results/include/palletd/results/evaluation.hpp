// palletd io: scoring detections against truth files (for `palletctl eval` and the benchmarks).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "palletd/detection/confidence.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/frames/frame_io.hpp"

namespace palletd {

struct EvalOptions {
  double exact_position_mm = 15.0;  ///< exact layout: every box within this ...
  double exact_yaw_deg = 2.0;       ///< ... and this
  /// The detector was given other formats than the truth's recipe (recipe_matches() false): the
  /// right answer is then recipe_mismatch, and any unflagged layout is wrong.
  bool recipe_wrong = false;
  /// A box whose size was measured (format -1) has the right size within this of the carton's [mm].
  double measured_size_mm = 10.0;
};

/// Whether `formats` are the truth's recipe (the same sizes, in any order, within 1 mm).
bool recipe_matches(const std::vector<BoxFormat>& formats, const Truth& truth);

/// One detected box against the truth: whether it is right, and what its confidence rests on.
struct BoxEval {
  double score = 0.0;
  /// Matched to a truth box within the exact tolerances (EvalOptions), with the right format.
  bool right = false;
  std::array<double, kBoxFeatures> features{};  ///< box_features() of its score terms
};

/// One frame's detection against its truth.
struct FrameEval {
  std::string frame;
  std::string status;         ///< the detection's status word
  std::string expect = "boxes";  ///< what the truth asks for: boxes, empty, slip_sheet (Truth::expect)
  bool ambiguous = false;
  std::string flag_reason;  ///< Detection::ambiguity_reason ("" when not flagged)
  std::size_t truth_boxes = 0, detected_boxes = 0, matched = 0;
  std::vector<double> position_errors_mm;  ///< per matched pair
  std::vector<double> yaw_errors_deg;      ///< per matched pair, mod 180
  /// Per matched pair whose size was measured (format -1, a size-range recipe): the larger of
  /// the two sides' differences from the carton's size [mm].
  std::vector<double> size_errors_mm;
  double pairwise_error_mm = 0.0;  ///< mean |d_ij(detected) - d_ij(truth)| over matched pairs (the paper's metric)
  bool formats_right = true;
  /// Boxes: no miss, no extra, all within tolerance, right formats. Empty or slip_sheet: the
  /// status says so.
  bool exact = false;
  /// Not exact, yet an answer the PLC acts on (ok, empty or slip_sheet) not flagged ambiguous:
  /// boxes where a sheet lies, an empty pallet or a sheet where cartons stand.
  bool unflagged_wrong = false;
  double runtime_ms = 0.0;
  std::map<std::string, double> timing_ms;  ///< Detection::timing_ms (per stage)
  std::vector<BoxEval> boxes;       ///< per detected box, in the detection's order
  double layout_confidence = 0.0;   ///< Detection::layout_confidence
  bool outline_unobserved = false;  ///< Detection::outline_unobserved
  bool recipe_wrong = false;         ///< EvalOptions::recipe_wrong
  std::optional<int> best_recipe;    ///< the recipe the detection named as fitting (recipe mismatch)
  std::optional<int> truth_recipe;   ///< the configured recipe with the truth's formats, when known
  /// Whether the truth's own outline determines its layout: 0 = yes (unambiguous: the
  /// detection must be exact), 1 = no (another layout fits the outline as well: exact or
  /// flagged ambiguous is right), -1 = not checked.
  int outline_tied = -1;
};

/// Matches detected to truth boxes (Hungarian assignment on centre distance, gated at a quarter
/// of the truth box's shorter side) and computes the errors. `format_names` maps the detection's
/// format index to the truth's format name ("" entries are not checked).
FrameEval evaluate_frame(const Detection& detection, const Truth& truth,
                         const std::vector<std::string>& format_names, const EvalOptions& options = {});

struct EvalSummary {
  std::size_t frames = 0, ok_frames = 0, exact_frames = 0, ambiguous_frames = 0;
  std::size_t truth_boxes = 0, detected_boxes = 0, matched = 0;
  double precision = 0.0, recall = 0.0, exact_rate = 0.0;
  double position_median_mm = 0.0, position_p95_mm = 0.0, position_max_mm = 0.0;
  double yaw_median_deg = 0.0, yaw_p95_deg = 0.0;
  /// Boxes whose size was measured (size-range recipe) and how far off the carton's size [mm].
  std::size_t size_measured = 0;
  double size_median_mm = 0.0, size_p95_mm = 0.0;
  double pairwise_mean_mm = 0.0;
  double runtime_median_ms = 0.0, runtime_p95_ms = 0.0;
  /// Ambiguity-aware counts over frames with outline_tied checked: unambiguous frames and how
  /// many were exact (and how many of them flagged ambiguous); tied frames resolved exactly,
  /// flagged ambiguous (not exact), or wrong and unflagged.
  std::size_t unambiguous_frames = 0, unambiguous_exact = 0, unambiguous_flagged = 0;
  std::size_t tied_frames = 0, tied_resolved = 0, tied_flagged = 0, tied_wrong = 0;
  double unambiguous_exact_rate = 0.0;
  std::size_t unflagged_wrong = 0;  ///< FrameEval::unflagged_wrong
  /// Frames whose truth expects `empty` or `slip_sheet`, and how many were answered so.
  std::size_t empty_frames = 0, empty_right = 0, sheet_frames = 0, sheet_right = 0;
  /// Frames detected with another recipe than their truth's, how many answered recipe_mismatch,
  /// named a best-fitting recipe, named the truth's; frames with the right recipe that answered
  /// recipe_mismatch all the same.
  std::size_t wrong_recipe_frames = 0, wrong_recipe_mismatch = 0, wrong_recipe_named = 0, wrong_recipe_named_right = 0;
  std::size_t false_mismatch = 0;
};

EvalSummary summarize(const std::vector<FrameEval>& frames);

/// Minimum-cost assignment of rows to columns (Hungarian method); cost[r][c]. Returns for each
/// row its column or -1 (when there are more rows than columns).
std::vector<int> assign_min_cost(const std::vector<std::vector<double>>& cost);

/// Percentile (0..100) of values by linear interpolation; 0 for an empty list.
double percentile(std::vector<double> values, double pct);

}  // namespace palletd
