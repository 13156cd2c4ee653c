// palletd detection without a recipe's formats: cartons nobody entered. The layer's outline and
// seams propose carton sizes within a size range; the combinatorial search lays each out, and the
// size whose layout the frame supports best, measured on its own boxes, is the answer.
//
//   Detection d = detect_unknown_cartons(frame, SizeRange{...}, params, workspace);
//   // d.formats_measured: every box has format -1 and the measured size (long_m, short_m)
#pragma once

#include <vector>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/layer.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

/// The cartons a size-range recipe allows: long and short side of the top face [m].
struct SizeRange {
  double long_min_m = 0.2, long_max_m = 0.8;
  double short_min_m = 0.15, short_max_m = 0.6;

  [[nodiscard]] bool admits(double long_m, double short_m) const {
    return long_m >= long_min_m && long_m <= long_max_m && short_m >= short_min_m && short_m <= short_max_m &&
           short_m <= long_m;
  }
};

/// How the candidate sizes are found and tried.
struct UnknownCartonParams {
  int max_candidates = 10;          ///< carton sizes laid out per frame (each one a layout search)
  double min_seam_share = 0.2;      ///< a seam line counts where it runs across this share of the layer
  double outline_margin_m = 0.012;  ///< seam cells this close to the outline are not looked at [m]
  double max_gap_m = kMaxCartonGap_m;  ///< widest gap between cartons the outline's division allows for [m]
  /// A runner-up size whose seam evidence reaches this share of the best one's makes the answer
  /// ambiguous (two cartons may look like one where a seam is not seen).
  double tie_ratio = 0.8;
  /// Below this seam evidence (the layer's area in boxes whose shared sides show seams and whose
  /// tops show none) the frame cannot tell one carton from two: the layout is flagged.
  double min_evidence = 0.35;
  /// The camera shows narrow seams (a gap under a pixel) only at a pitch up to this on the layer,
  /// and where depths mix across edges along at least this share of the outline (a time-of-flight
  /// camera; a stereo or structured-light camera smooths them away and fattens the tops):
  /// elsewhere a layout of unknown cartons is flagged, one carton cannot be told from two.
  double max_pitch_mm = 10.0;
  double min_rim_share = 0.3;
  /// A size whose layout covers less of the layer than this leaves cartons unexplained: flagged.
  double min_coverage = 0.92;
  /// Where the intensity image shows the layer's outer edges more than this many pixel pitches
  /// inside the depth's outline, the depth fattens the tops (a stereo camera's block matching;
  /// a time-of-flight camera's depth and amplitude share each pixel and agree within a third of
  /// a pixel): sizes measured on the outline run large, the layout is flagged.
  double max_edge_offset_px = 1.0;
};

/// A carton size the layer suggests, with how much of the frame proposes it.
struct SizeCandidate {
  BoxFormat format;
  double support = 0.0;  ///< seam lines and outline sides spaced by its sides (larger: more)
};

/// Carton sizes within `range` that the layer's outline and seams suggest, best supported first:
/// side lengths from the spacings of seam lines across the layer (and of the outline's sides),
/// paired so that each component's sides are whole numbers of cartons plus gaps.
std::vector<SizeCandidate> candidate_sizes(const LayerResult& layer, const SeamEvidence& seams,
                                           const SizeRange& range, const UnknownCartonParams& params);

/// The whole detection with cartons of unknown size: each candidate size laid out by detect(),
/// ranked by layout confidence and by how well its boxes' measured sides agree with it; the
/// winner detected again with the size measured on its boxes. Boxes have format -1;
/// Detection::formats_measured is set. A runner-up size that fits nearly as well flags the layout.
Detection detect_unknown_cartons(const Frame& frame, const SizeRange& range, const DetectionParams& params,
                                 DetectionWorkspace& workspace, const UnknownCartonParams& unknown = {});

}  // namespace palletd
