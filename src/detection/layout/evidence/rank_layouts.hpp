// Private to the layout stage: choosing among a component's candidate layouts whose outline
// scores are near-equal, by the seams between the boxes, and settling the outline-equal
// footprint moves of mixed-format layers (find_layout.cpp calls these in that order).
#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "evidence/seam_likelihood.hpp"
#include "layout_internal.hpp"

namespace palletd::layout_detail {

/// One candidate layout of a component: its boxes in a layout frame and their outline score.
struct Candidate {
  LayoutFrame frame;
  std::vector<FrameBox> boxes;
  double score = 0.0;           ///< outline score Area(B ∩ C) summed over the boxes [m^2]
  std::size_t orientation = 0;  ///< index of its frame in ComponentFrames
};

struct SeamJudge;

/// A component turned into each layout frame searched; the seam table and the seam likelihood
/// of a frame are built the first time they are asked for.
class ComponentFrames {
 public:
  /// Adds a frame with the component turned into it; returns its index.
  std::size_t add(const LayoutFrame& frame, PolygonWithHoles frame_polygon);
  [[nodiscard]] std::size_t size() const { return frames_.size(); }
  [[nodiscard]] bool empty() const { return frames_.empty(); }
  [[nodiscard]] const LayoutFrame& frame(std::size_t i) const { return frames_[i]; }
  [[nodiscard]] const PolygonWithHoles& polygon(std::size_t i) const { return polygons_[i]; }
  /// The seam table of frame i; null without seams or when the table is empty.
  const SeamTable* table(std::size_t i, const SeamEvidence* seams);
  /// The seam likelihood of frame i (the seams and tape rastered into it once; calibrate() it
  /// for the layouts at hand before each use); the tape alone where the judge has only
  /// SeamJudge::tape; null without either.
  SeamLikelihood* likelihood(std::size_t i, const SeamJudge& judge, double margin_m);

 private:
  std::vector<LayoutFrame> frames_;
  std::vector<PolygonWithHoles> polygons_;
  std::vector<SeamTable> tables_;
  std::vector<std::unique_ptr<SeamLikelihood>> likelihoods_;
};

/// The seam evidence and the recipe figures the ranking phases share.
struct SeamJudge {
  const SeamEvidence* seams = nullptr;  ///< null when the frame has no usable seam evidence
  /// Where `seams` is null: the raster with the tops' intensity, whose seams show nothing (a
  /// single carton, pressed cartons on a stereo camera). The tape along the cartons' flaps is read
  /// from it (SeamLikelihood with no usable seams); null without intensity.
  const SeamEvidence* tape = nullptr;
  double min_short_m = 0.0;             ///< shortest box side of the recipe [m]
  double min_long_m = 0.0;              ///< shortest long side of the recipe's formats [m]
  double merge_tol_m = 0.0;             ///< how far a seam may lie from a box side [m]
  double absent_cap_nats = 0.0;         ///< SeamLikelihood's cap on absent seams' evidence
};

/// The candidates (sorted by outline score, best first) within `tie_margin_m2` of the best that
/// are materially different from each other (same frame and boxes within `same_tol_m`: the
/// same). Indices into `sorted`, the best first.
std::vector<std::size_t> near_equal_candidates(const std::vector<Candidate>& sorted, double tie_margin_m2,
                                               double same_tol_m);

/// The near-equal candidates in the order the seams prefer them, and whether the seams settle it.
struct Ranking {
  std::vector<std::size_t> order;  ///< indices into the candidates, the chosen one first
  bool ambiguous = false;
};

/// Ranks the near-equal candidates: by the seam likelihood (seam_likelihood.hpp) when they share
/// a layout frame and the frame's seams stand out of its box tops, else by the seam agreement
/// along whole box edges. One candidate: itself, not ambiguous; several without seams: tied.
Ranking rank_by_seams(const std::vector<Candidate>& cands, const std::vector<std::size_t>& near,
                      ComponentFrames& frames, const SeamJudge& judge, const LayoutParams& params);

/// Outline-equal footprint moves of `best` (a box or two turned into other boxes of the recipe on
/// the same rectangle), decided one at a time by the seams and applied to `best`. Returns
/// whether a move the seams cannot decide remains (-> ambiguous).
bool settle_footprint_moves(Candidate& best, const std::vector<Candidate>& cands,
                            const std::vector<std::size_t>& near, ComponentFrames& frames,
                            const std::vector<BoxFormat>& formats, const SeamJudge& judge,
                            const LayoutParams& params);

/// The near-equal candidates the seams could not rank (`ranking`, ambiguous) as the search gave
/// them, each with its own footprint moves settled first (each calibrated against the others as
/// they came, and written back into `cands`): those that settled into the layout of an earlier
/// one (the same frame, boxes within `same_tol_m`) are one, and those still different are ranked
/// again for the best guess. No tie only where all settled into one layout (mixes of an absent
/// larger format whose boxes split into the cartons they cover) and its moves were decided.
Ranking settle_then_rank(std::vector<Candidate>& cands, const std::vector<std::size_t>& near, Ranking ranking,
                         ComponentFrames& frames, const std::vector<BoxFormat>& formats,
                         const SeamJudge& judge, const LayoutParams& params, double same_tol_m);

}  // namespace palletd::layout_detail
