// Private to the layout stage: seam evidence as a likelihood ratio that decides between
// near-equal candidate layouts of one layout frame.
//
// Two layouts of the same outline differ only where one predicts a seam (an interior box side)
// and the other predicts a box top. Along each piece of predicted seam, the measured seam
// contrast (seam raster on the line against the box tops beside it) is compared with two
// distributions taken from the frame itself: "no seam" from lines across box interiors that no
// candidate predicts as a seam, and "seam" from the seams every candidate predicts (so pressed
// boxes with faint gaps calibrate themselves). Each piece gives a capped log-likelihood ratio (a
// missing seam capped at half a clear one: gaps can be pressed shut);
// each maximal run of pieces where two layouts disagree counts with the median of its pieces
// times its length, so short interior edges (tape, labels) and scattered dropouts do not decide.
// When the frame's seams are not distinguishable from its box tops, the evidence is zero and the
// tie stays a tie (ambiguous). Along an axis where the frame shows no reference seam at all, a
// missing seam counts for nothing (gaps can be pressed shut along one direction), a clear one
// still counts.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "evidence/tape.hpp"
#include "layout_internal.hpp"

namespace palletd::layout_detail {

class SeamLikelihood {
 public:
  /// `seams` raw raster in the layer frame; `frame_polygon` the component in `frame`.
  /// `position_tol_m`: how far a measured seam may lie from a predicted box side [m].
  /// `absent_cap_nats`: cap of the summed evidence of seams that are predicted and absent
  /// (infinity: none). Set below decisive_nats, absent seams alone never decide: a gap can be
  /// pressed shut, so a decision needs a seam that shows. Without `read_seams` only the tape is
  /// read (a raster whose seams show nothing): calibrate() finds nothing to judge the seams by.
  SeamLikelihood(const SeamEvidence& seams, const LayoutFrame& frame, const PolygonWithHoles& frame_polygon,
                 double position_tol_m, double margin_m, double absent_cap_nats, bool read_seams = true);
  [[nodiscard]] bool empty() const { return w_ == 0; }

  /// Calibrates the two contrast distributions from the candidates (all of the same frame):
  /// pieces every candidate predicts as seams (when they share fewer than four, the strongest
  /// 1/k of the pieces the k candidates predict: one of them is right), and lines across box
  /// interiors no candidate predicts. Returns false when the seams are not distinguishable from
  /// the box tops.
  bool calibrate(const std::vector<const std::vector<FrameBox>*>& candidates);
  [[nodiscard]] bool usable() const { return usable_; }
  /// The last calibration had enough reference pieces to judge the seams (usable() or not).
  [[nodiscard]] bool measured() const { return measured_; }

  /// The intensity shows the tops (tape along cartons' flaps can be read): compare() weighs it
  /// even where the seams are not usable.
  [[nodiscard]] bool reads_tape() const { return !tape_.empty(); }

  /// Both layouts have bands of tape along boxes the other has not: whichever wins, a band the
  /// other found runs where the winner has no carton's middle (neither explains all the tape).
  [[nodiscard]] bool tape_splits(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const {
    return tape_.only_m(a, b) > 0.0 && tape_.only_m(b, a) > 0.0;
  }

  /// Evidence [nats] that layout a rather than b explains the seams and the tape along the
  /// cartons' flaps (antisymmetric); the tape alone where the seams are not usable. Without the
  /// tape where tape_splits(a, b).
  [[nodiscard]] double compare(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b,
                               bool with_tape = true) const;
  /// TapeEvidence::unexplained_band_m() of the boxes [m].
  [[nodiscard]] double unexplained_band_m(const std::vector<FrameBox>& boxes,
                                          double shortest_carton_m) const {
    return tape_.unexplained_band_m(boxes, shortest_carton_m);
  }
  /// Evidence that decides [nats]: a clear seam along half of the shortest box side.
  [[nodiscard]] static double decisive_nats(double min_short_m);

  /// Noise figures for diagnostics and tests.
  [[nodiscard]] double null_median() const { return mu0_; }
  [[nodiscard]] double null_sigma() const { return sigma0_; }
  [[nodiscard]] double seam_median() const { return mu1_; }

  /// A piece of predicted seam: line axis (vertical = constant x), line position key, index
  /// along the line.
  struct PieceKey {
    bool vertical;
    std::int64_t pos_key;
    std::int64_t index;
    bool operator<(const PieceKey& o) const {
      if (vertical != o.vertical) return vertical < o.vertical;
      if (pos_key != o.pos_key) return pos_key < o.pos_key;
      return index < o.index;
    }
  };
  /// Interior seam pieces of a layout with their line position [m].
  [[nodiscard]] std::map<PieceKey, double> pieces(const std::vector<FrameBox>& boxes) const;

 private:
  /// Whether a side of one of the boxes runs along the piece (its whole length, corners included).
  [[nodiscard]] static bool along_a_side(const std::vector<FrameBox>& boxes, const PieceKey& key);
  [[nodiscard]] double contrast(const PieceKey& k, double pos) const;
  [[nodiscard]] double llr(double c) const;
  /// llr() for a piece on a line of the given axis: where the frame shows no seam reference
  /// along that axis, a missing seam is no evidence (seams pressed shut along one direction,
  /// as on a pallet filled edge to edge, look like box tops); a clear seam still is.
  [[nodiscard]] double llr(double c, bool vertical) const;
  [[nodiscard]] double strip_mean(double x0, double y0, double x1, double y1) const;
  [[nodiscard]] double tape_nats(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const;

  const PolygonWithHoles* polygon_;
  double tol_ = 0.01, margin_ = 0.012;
  double x0_ = 0, y0_ = 0, cell_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<double> sat_;
  double mu0_ = 0, sigma0_ = 0, mu1_ = 0, sigma1_ = 0;
  std::size_t axis_seams_[2] = {0, 0};  ///< seam reference pieces per axis ([1]: vertical lines)
  bool read_seams_ = true;
  bool usable_ = false;
  bool measured_ = false;
  double absent_cap_ = 0;  ///< [nats]
  TapeEvidence tape_;
};

/// An outline-equal change of a layout: the boxes `remove` (indices) give way to `add`, which
/// tile the same rectangle (a box split into two boxes of the recipe, e.g. a 600 x 400 into two
/// 400 x 300 side by side; two boxes merged into one; two boxes split the other way).
struct FootprintMove {
  std::vector<std::size_t> remove;
  std::vector<FrameBox> add;
};
/// Every footprint move of a layout (single boxes and pairs sharing a whole side); sizes match
/// within tol_m.
std::vector<FootprintMove> footprint_moves(const std::vector<FrameBox>& boxes, const std::vector<BoxFormat>& formats,
                                           double tol_m);
/// Every split of one box into two boxes of the recipe that fall short of it by more than tol_m
/// and at most slack_m along each side (a larger box laid over two cartons and their gaps);
/// a few placements of each within the box's rectangle.
std::vector<FootprintMove> split_moves(const std::vector<FrameBox>& boxes,
                                       const std::vector<BoxFormat>& formats, double tol_m, double slack_m);
/// The layout with every move applied at once (moves may overlap: for calibration only).
std::vector<FrameBox> moves_overlay(const std::vector<FrameBox>& boxes, const std::vector<FootprintMove>& moves);

struct RetileResult {
  bool tied = false;        ///< a move the seams could not decide remains (-> ambiguous)
  std::size_t applied = 0;  ///< moves the seams decided for
};
/// Footprint moves decided by the seams: the search keeps only a few near-equal layouts, but a
/// layer with several formats has 2^n outline-equal ones (each 600 x 400 box or two 400 x 300).
/// The moves are independent (each changes the pieces inside its footprint only), so they are
/// decided one at a time: the move with the strongest evidence above decisive_nats is applied,
/// until none is left. Without usable seams, any move is a tie. Where the seams are usable, a
/// split_moves() split (slack_m) is applied when its evidence decides; undecided it is no tie
/// (the outline preferred the larger box). `lik` may be null.
RetileResult retile_by_seams(std::vector<FrameBox>* boxes, const std::vector<BoxFormat>& formats,
                             const SeamLikelihood* lik, double tol_m, double slack_m, double decisive_nats);

}  // namespace palletd::layout_detail
