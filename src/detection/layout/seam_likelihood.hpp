// Private to the layout stage: seam evidence as a likelihood ratio that decides between
// near-equal candidate layouts of one layout frame.
//
// Two layouts of the same outline differ only where one predicts a seam (an interior box side)
// and the other predicts a box top. Along each piece of predicted seam, the measured seam
// contrast (seam raster on the line against the box tops beside it) is compared with two
// distributions taken from the frame itself: "no seam" from lines across box interiors that no
// candidate predicts as a seam, and "seam" from the seams every candidate predicts (so pressed
// boxes with faint gaps calibrate themselves). Each piece gives a capped log-likelihood ratio;
// each maximal run of pieces where two layouts disagree counts with the median of its pieces
// times its length, so short interior edges (tape, labels) and scattered dropouts do not decide.
// When the frame's seams are not distinguishable from its box tops, the evidence is zero and the
// tie stays a tie (ambiguous).
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "layout_internal.hpp"

namespace palletd::layout_detail {

class SeamLikelihood {
 public:
  /// `seams` raw raster in the layer frame; `frame_polygon` the component in `frame`.
  /// `position_tol_m`: how far a measured seam may lie from a predicted box side [m].
  SeamLikelihood(const SeamEvidence& seams, const LayoutFrame& frame, const PolygonWithHoles& frame_polygon,
                 double position_tol_m, double margin_m);
  [[nodiscard]] bool empty() const { return w_ == 0; }

  /// Calibrates the two contrast distributions from the candidates (all of the same frame):
  /// pieces every candidate predicts as seams, and lines across box interiors no candidate
  /// predicts. Returns false when the seams are not distinguishable from the box tops.
  bool calibrate(const std::vector<const std::vector<FrameBox>*>& candidates);
  [[nodiscard]] bool usable() const { return usable_; }

  /// Evidence [nats] that layout a rather than b explains the seams (antisymmetric).
  [[nodiscard]] double compare(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const;

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
  [[nodiscard]] double contrast(const PieceKey& k, double pos) const;
  [[nodiscard]] double llr(double c) const;
  [[nodiscard]] double strip_mean(double x0, double y0, double x1, double y1) const;

  const PolygonWithHoles* polygon_;
  double tol_ = 0.01, margin_ = 0.012;
  double x0_ = 0, y0_ = 0, cell_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<double> sat_;
  double mu0_ = 0, sigma0_ = 0, mu1_ = 0, sigma1_ = 0;
  bool usable_ = false;
};

}  // namespace palletd::layout_detail
