// Tape along a carton's flaps (see tape.hpp).
#include "evidence/tape.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/core/statistics.hpp"

#include "evidence/seam_raster.hpp"

namespace palletd::layout_detail {

namespace {

constexpr double kEnd_m = 0.03;    ///< the middle line's ends left out (flap corners, bevels) [m]
constexpr double kTapePiece_m = 0.02;  ///< the middle line is read in pieces of this length [m]
/// The band's two halves: from kBandIn_m to kBandOut_m either side of the middle line (a 48 mm
/// band; the middle itself is left out, where the flaps' own gap may show as a dark line) [m].
constexpr double kBandIn_m = 0.006, kBandOut_m = 0.022;
/// The board beside the band: from kFlankIn_m to kFlankOut_m either side, kFlankEnd_m clear of the
/// box's sides [m].
constexpr double kFlankIn_m = 0.04, kFlankOut_m = 0.07, kFlankEnd_m = 0.012;
/// A band differs from the board beside it by at least this share of the board's intensity, by
/// kNoiseK times the noise of the difference, and along kSameShare of the pieces.
constexpr double kMinContrast = 0.06;
constexpr double kNoiseK = 4.0;
constexpr double kSameShare = 0.8;
/// A reading needs this share of its rectangle seen on the tops.
constexpr double kMinSeen = 0.5;
/// A band the layer shows runs at least this long [m], and at least kMinRunShare of the shortest
/// carton; a box's middle line within kExplain_m of it, along at least half of it, explains it.
constexpr double kMinRun_m = 0.12, kMinRunShare = 0.5, kExplain_m = 0.035;
/// How far from the box's middle line the band is looked for, and in steps of at least [m].
constexpr double kShift_m = 0.024, kShiftStep_m = 0.004;
/// Boxes of two layouts whose sides lie within this of each other are the same carton [m].
constexpr double kSameBox_m = 0.02;

bool same_carton(const FrameBox& a, const FrameBox& b) {
  return a.long_along_x == b.long_along_x && std::abs(a.rect.x0 - b.rect.x0) < kSameBox_m &&
         std::abs(a.rect.x1 - b.rect.x1) < kSameBox_m && std::abs(a.rect.y0 - b.rect.y0) < kSameBox_m &&
         std::abs(a.rect.y1 - b.rect.y1) < kSameBox_m;
}

}  // namespace

TapeEvidence::TapeEvidence(const SeamEvidence& seams, const LayoutFrame& frame, double x0_m, double y0_m,
                           int width, int height)
    : x0_(x0_m), y0_(y0_m), cell_(seams.cell_m) {
  if (seams.tops.empty() || seams.tops_seen.size() != seams.tops.size() || width <= 0 || height <= 0) return;
  w_ = width;
  h_ = height;
  // Intensity x seen and seen, each interpolated: their ratio is the mean over the tops seen.
  const cv::Mat tops = raster_in_frame(seams.tops, seams, frame, x0_m, y0_m, width, height);
  const cv::Mat seen = raster_in_frame(seams.tops_seen, seams, frame, x0_m, y0_m, width, height);
  integral_into(tops, sum_);
  integral_into(seen, seen_);
}

double TapeEvidence::mean(double x0, double y0, double x1, double y1, double* seen_share) const {
  const auto cells = [&](double v, double origin, int n) {
    return std::clamp((v - origin) / cell_, 0.0, static_cast<double>(n));
  };
  const double fx0 = cells(x0, x0_, w_), fx1 = cells(x1, x0_, w_);
  const double fy0 = cells(y0, y0_, h_), fy1 = cells(y1, y0_, h_);
  const double area = (fx1 - fx0) * (fy1 - fy0);
  const double seen = area > 0.0 ? sat_sum_bilinear(seen_, w_, h_, fx0, fy0, fx1, fy1) : 0.0;
  *seen_share = area > 0.0 ? seen / area : 0.0;
  return seen > 0.0 ? sat_sum_bilinear(sum_, w_, h_, fx0, fy0, fx1, fy1) / seen : 0.0;
}

TapeEvidence::Band TapeEvidence::band_along(const FrameBox& box, double offset_m) const {
  const Rect& r = box.rect;
  // Along the long axis (a) and across it (c), in frame coordinates.
  const bool along_x = box.long_along_x;
  const double a0 = (along_x ? r.x0 : r.y0) + kEnd_m, a1 = (along_x ? r.x1 : r.y1) - kEnd_m;
  const double mid = (along_x ? 0.5 * (r.y0 + r.y1) : 0.5 * (r.x0 + r.x1)) + offset_m;
  const double half = 0.5 * (along_x ? r.y1 - r.y0 : r.x1 - r.x0);
  const double flank_out = std::min(kFlankOut_m, half - kFlankEnd_m - std::abs(offset_m));
  const int n = static_cast<int>((a1 - a0) / kTapePiece_m);
  if (n < 5 || flank_out < kFlankIn_m + 2 * cell_) return {};
  const auto read = [&](double s0, double s1, double c0, double c1, bool* ok) {
    double seen = 0.0;
    const double v =
        along_x ? mean(s0, mid + c0, s1, mid + c1, &seen) : mean(mid + c0, s0, mid + c1, s1, &seen);
    *ok = *ok && seen >= kMinSeen;
    return v;
  };
  std::vector<double> bands, halves, boards;
  for (int k = 0; k < n; ++k) {
    const double s0 = a0 + k * kTapePiece_m, s1 = s0 + kTapePiece_m;
    bool ok = true;
    const double lo = read(s0, s1, -kBandOut_m, -kBandIn_m, &ok),
                 hi = read(s0, s1, kBandIn_m, kBandOut_m, &ok);
    const double board =
        0.5 * (read(s0, s1, -flank_out, -kFlankIn_m, &ok) + read(s0, s1, kFlankIn_m, flank_out, &ok));
    if (!ok) continue;
    const double cl = lo - board, ch = hi - board;
    bands.push_back(cl * ch > 0.0 ? std::copysign(std::min(std::abs(cl), std::abs(ch)), cl) : 0.0);
    halves.push_back(cl - ch);
    boards.push_back(board);
  }
  if (bands.size() < 5 || static_cast<int>(bands.size()) * 5 < n * 3) return {};
  Band b;
  b.length_m = a1 - a0;
  b.contrast = upper_median(bands);
  b.board = upper_median(std::move(boards));
  const double halves_med = upper_median(halves);
  for (double& d : halves) d = std::abs(d - halves_med);
  b.sigma = 1.4826 * upper_median(std::move(halves)) / std::sqrt(2.0);  // one half's contrast
  const auto same = std::count_if(bands.begin(), bands.end(), [&](double x) {
    return x * b.contrast > 0.0 && std::abs(x) >= 0.5 * std::abs(b.contrast);
  });
  b.same_share = static_cast<double>(same) / static_cast<double>(bands.size());
  return b;
}

double TapeEvidence::taped_length_m(const FrameBox& box) const {
  if (empty()) return 0.0;
  // The search places boxes at their nominal size: the carton's middle may lie a gap and its
  // oversize away from the box's.
  for (double o = -kShift_m; o <= kShift_m + 1e-9; o += std::max(cell_, kShiftStep_m)) {
    const Band b = band_along(box, o);
    if (b.length_m > 0.0 && std::abs(b.contrast) >= kMinContrast * b.board &&
        std::abs(b.contrast) >= kNoiseK * b.sigma && b.same_share >= kSameShare)
      return b.length_m;
  }
  return 0.0;
}

std::size_t TapeEvidence::PlacementHash::operator()(const Placement& p) const {
  std::uint64_t h = p.long_along_x ? 0x9e3779b97f4a7c15ULL : 0ULL;
  for (const std::uint64_t bits : p.rect_bits) h = (h ^ bits) * 0x100000001b3ULL + (h >> 29);
  return static_cast<std::size_t>(h);
}

double TapeEvidence::taped_length_kept_m(const FrameBox& box) const {
  Placement key;
  const double corners[4] = {box.rect.x0, box.rect.y0, box.rect.x1, box.rect.y1};
  std::memcpy(key.rect_bits.data(), corners, sizeof corners);
  key.long_along_x = box.long_along_x;
  const auto [it, added] = taped_.try_emplace(key, 0.0);
  if (added) it->second = taped_length_m(box);
  return it->second;
}

double TapeEvidence::only_m(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const {
  if (empty()) return 0.0;
  double m = 0.0;
  for (const FrameBox& box : a) {
    const bool shared =
        std::any_of(b.begin(), b.end(), [&](const FrameBox& o) { return same_carton(box, o); });
    if (!shared) m += taped_length_kept_m(box);
  }
  return m;
}

double TapeEvidence::compare_m(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const {
  return only_m(a, b) - only_m(b, a);
}

double TapeEvidence::band_piece(bool along_x, double c, double s0, double s1, double* board) const {
  const auto read = [&](double c0, double c1, bool* ok) {
    double seen = 0.0;
    const double v = along_x ? mean(s0, c + c0, s1, c + c1, &seen) : mean(c + c0, s0, c + c1, s1, &seen);
    *ok = *ok && seen >= kMinSeen;
    return v;
  };
  bool ok = true;
  const double lo = read(-kBandOut_m, -kBandIn_m, &ok), hi = read(kBandIn_m, kBandOut_m, &ok);
  const double left = read(-kFlankOut_m, -kFlankIn_m, &ok), right = read(kFlankIn_m, kFlankOut_m, &ok);
  *board = 0.5 * (left + right);
  if (!ok) return 0.0;
  // Both halves against both sides, one sign: a seam or an edge beside the line darkens one side only.
  const double d[4] = {lo - left, lo - right, hi - left, hi - right};
  double band = d[0];
  for (double x : d) {
    if (x * d[0] <= 0.0) return 0.0;
    if (std::abs(x) < std::abs(band)) band = x;
  }
  return band;
}

double TapeEvidence::unexplained_band_m(const std::vector<FrameBox>& boxes, double shortest_carton_m) const {
  if (empty()) return 0.0;
  const double min_run_m = std::max(kMinRun_m, kMinRunShare * shortest_carton_m);
  const double step = std::max(cell_, kShiftStep_m);
  double longest = 0.0;
  for (const bool along_x : {true, false}) {
    const double c_lo = (along_x ? y0_ : x0_) + kFlankOut_m;
    const double c_hi = (along_x ? y0_ + h_ * cell_ : x0_ + w_ * cell_) - kFlankOut_m;
    const double s_lo = along_x ? x0_ : y0_;
    const int n = static_cast<int>(((along_x ? w_ : h_) * cell_) / kTapePiece_m);
    const auto explained = [&](double c, double a0, double a1) {
      return std::any_of(boxes.begin(), boxes.end(), [&](const FrameBox& b) {
        const Rect& r = b.rect;
        const double mid = along_x ? 0.5 * (r.y0 + r.y1) : 0.5 * (r.x0 + r.x1);
        const double b0 = along_x ? r.x0 : r.y0, b1 = along_x ? r.x1 : r.y1;
        return b.long_along_x == along_x && std::abs(mid - c) <= kExplain_m &&
               std::min(a1, b1) - std::max(a0, b0) >= 0.5 * (a1 - a0);
      });
    };
    for (double c = c_lo; c <= c_hi; c += step) {
      int run = 0;
      double sign = 0.0;
      for (int k = 0; k <= n; ++k) {
        double board = 0.0;
        const double band =
            k < n ? band_piece(along_x, c, s_lo + k * kTapePiece_m, s_lo + (k + 1) * kTapePiece_m, &board)
                  : 0.0;
        const bool piece = band != 0.0 && std::abs(band) >= kMinContrast * board && band * sign >= 0.0;
        if (piece) {
          ++run;
          sign = band;
          continue;
        }
        const double a1 = s_lo + k * kTapePiece_m, a0 = a1 - run * kTapePiece_m;
        if (run * kTapePiece_m >= min_run_m - 1e-9 && !explained(c, a0, a1))
          longest = std::max(longest, a1 - a0);
        run = band != 0.0 && std::abs(band) >= kMinContrast * board ? 1 : 0;  // a band of the other sign
        sign = run > 0 ? band : 0.0;
      }
    }
  }
  return longest;
}

namespace {

/// The tops' intensity read in a frame along the box: its long side along x, its centre at the
/// origin (the box is {-hx, -hy, hx, hy} there).
TapeEvidence tape_along(const Box2d& box, const SeamEvidence& seams) {
  LayoutFrame frame;
  frame.theta_rad = box.yaw_rad;
  frame.pivot = box.center;
  const double pad_m = 0.05, hx = 0.5 * box.long_m, hy = 0.5 * box.short_m;
  const auto cells = [&](double half_m) {
    return static_cast<int>(std::ceil(2.0 * (half_m + pad_m) / seams.cell_m));
  };
  return TapeEvidence(seams, frame, -hx - pad_m, -hy - pad_m, cells(hx), cells(hy));
}

}  // namespace

bool taped(const Box2d& box, const SeamEvidence& seams, bool across) {
  if (seams.tops.empty()) return false;
  const double hx = 0.5 * box.long_m, hy = 0.5 * box.short_m;
  return tape_along(box, seams).taped_length_m({{-hx, -hy, hx, hy}, box.format, !across}) > 0.0;
}

bool taped_in_halves(const Box2d& box, const SeamEvidence& seams) {
  constexpr double kMinAspect = 1.15;  // a half's long over short side whose tape tells its way round
  if (seams.tops.empty() || box.short_m < kMinAspect * 0.5 * box.long_m) return false;
  const TapeEvidence tape = tape_along(box, seams);
  const double hx = 0.5 * box.long_m, hy = 0.5 * box.short_m;
  // Each half is a carton whose long side runs along y: its tape along its own middle line.
  return tape.taped_length_m({{-hx, -hy, 0.0, hy}, box.format, false}) > 0.0 &&
         tape.taped_length_m({{0.0, -hy, hx, hy}, box.format, false}) > 0.0 &&
         tape.taped_length_m({{-hx, -hy, hx, hy}, box.format, true}) <= 0.0;
}

}  // namespace palletd::layout_detail
