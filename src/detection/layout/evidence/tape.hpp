// Private to the layout stage: tape along a carton's flaps as evidence of where the carton is.
//
// A regular slotted carton closes with two flaps that meet along the middle of its top,
// lengthwise, and are taped there: a band about 48 mm wide, lighter or darker than the board,
// from one end of the top to the other. In the intensity image such a band says which way a
// carton lies and where its middle is, where pressed cartons show no seam at all: two 400 x 300
// cartons side by side carry two bands across what one 600 x 400 would carry one band along, and
// a pinwheel's mirror image turns every band by 90 degrees. A box whose middle line shows a band
// is supported by it; a box without one is not evidence against it (cartons need not be taped,
// tape may match the board).
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "layout_internal.hpp"

namespace palletd::layout_detail {

class TapeEvidence {
 public:
  TapeEvidence() = default;
  /// The tops' intensity (SeamEvidence::tops) read in `frame` over the rectangle of cells
  /// (x0_m, y0_m, width x height cells of seams.cell_m); empty without it.
  TapeEvidence(const SeamEvidence& seams, const LayoutFrame& frame, double x0_m, double y0_m, int width,
               int height);
  [[nodiscard]] bool empty() const { return w_ == 0; }

  /// Length of the box's middle line along which a band runs [m]: the whole line between 30 mm
  /// off either end when a band shows along it, else 0.
  [[nodiscard]] double taped_length_m(const FrameBox& box) const;
  /// The reading above, for a box placed exactly so (its rectangle's bits and its way round):
  /// kept, because layouts compared in pairs share most of their boxes.
  [[nodiscard]] double taped_length_kept_m(const FrameBox& box) const;

  /// Taped length of the boxes of `a` that `b` has no box like (same way round, sides within
  /// 20 mm) [m].
  [[nodiscard]] double only_m(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const;
  /// The longest band of tape the layer shows (along either axis of the frame) that runs along
  /// no box's middle line [m]; 0 when every band is some box's. A band counts when it runs
  /// 120 mm and half of `shortest_carton_m` (the recipe's shortest long side) or more: a carton's
  /// tape runs the whole length of its top, a shipping label (100 x 150 mm, A6) or a print
  /// along a carton is shorter.
  [[nodiscard]] double unexplained_band_m(const std::vector<FrameBox>& boxes,
                                          double shortest_carton_m = 0.0) const;
  /// only_m(a, b) - only_m(b, a) [m].
  [[nodiscard]] double compare_m(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const;

 private:
  /// A band read along a box's middle line moved across by offset_m: its contrast against the
  /// board beside it (median over the pieces, signed), the board's intensity, the noise of one
  /// half's contrast, the share of pieces that agree with the median; length_m 0 when too
  /// little of the line is seen.
  struct Band {
    double length_m = 0.0, contrast = 0.0, board = 0.0, sigma = 0.0, same_share = 0.0;
  };
  [[nodiscard]] Band band_along(const FrameBox& box, double offset_m) const;
  /// The band's contrast on the piece [s0, s1] of the line at c (along x or y), against the
  /// board on both sides (0 unless both halves differ from both sides with one sign); `board`
  /// the board's intensity.
  [[nodiscard]] double band_piece(bool along_x, double c, double s0, double s1, double* board) const;
  /// Mean intensity of the tops seen in the frame rectangle, and the share of it seen.
  [[nodiscard]] double mean(double x0, double y0, double x1, double y1, double* seen_share) const;

  /// A box placed exactly: its rectangle's four coordinates (bits) and whether its long side is along x.
  struct Placement {
    std::array<std::uint64_t, 4> rect_bits{};
    bool long_along_x = true;
    bool operator==(const Placement& o) const {
      return rect_bits == o.rect_bits && long_along_x == o.long_along_x;
    }
  };
  struct PlacementHash {
    std::size_t operator()(const Placement& p) const;
  };

  double x0_ = 0, y0_ = 0, cell_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<double> sum_, seen_;  ///< summed-area tables of intensity x seen, and of seen
  mutable std::unordered_map<Placement, double, PlacementHash> taped_;  ///< taped_length_m() per placement
};

/// Whether a band runs along the middle of `box` (layer frame) in the tops' intensity; with
/// `across`, along its middle line across it (parallel to its short side).
bool taped(const Box2d& box, const SeamEvidence& seams, bool across = false);

/// Whether a band runs across `box` along the middle of each of its halves (the box cut across its
/// long side), and none along the box's own middle: two cartons side by side, each taped
/// lengthwise, under one box. Only where a half's long side runs across the box (the box's short
/// side 1.15 times half its long side or more), else a half's tape runs along the box.
bool taped_in_halves(const Box2d& box, const SeamEvidence& seams);

}  // namespace palletd::layout_detail
