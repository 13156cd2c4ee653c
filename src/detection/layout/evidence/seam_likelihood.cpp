// Seam evidence as a likelihood ratio between candidate layouts (see seam_likelihood.hpp).
#include "evidence/seam_likelihood.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/core/statistics.hpp"

#include "evidence/seam_raster.hpp"

namespace palletd::layout_detail {

namespace {

constexpr double kPiece_m = 0.02;  ///< length of one piece of predicted seam [m]
constexpr double kKey_m = 0.001;   ///< line positions closer than this are the same line [m]
constexpr double kNullSigmaFloor = 0.02;  ///< smallest noise of a piece's contrast [raster units]
/// Cap of one piece's log-likelihood ratio [nats] (odds of 20:1): no single spot decides.
constexpr double kPieceCap = 3.0;
/// Cap of a piece's evidence against a seam [nats]: a seam that is there shows (a gap, the dip
/// of two bevelled edges, a dark line in the intensity), but one that does not show may be a gap
/// pressed shut, so a missing seam weighs at most half of a clear one (the measurement behind
/// the half is in the history of this line).
constexpr double kMissingSeamCap = 0.5 * kPieceCap;
/// Evidence of a band of tape along a box's middle line [nats per m]: half of a clear seam of
/// the same length (it shows one carton's middle; a seam shows two cartons' sides). A band along
/// a whole 400 x 300 carton decides between layouts whose shortest box side is 300 mm.
constexpr double kTapeNatsPerM = 0.5 * kPieceCap / kPiece_m;

double mad_sigma(const std::vector<double>& v, double med) {
  std::vector<double> d;
  d.reserve(v.size());
  for (double x : v) d.push_back(std::abs(x - med));
  return 1.4826 * upper_median(std::move(d));
}

}  // namespace

SeamLikelihood::SeamLikelihood(const SeamEvidence& seams, const LayoutFrame& frame,
                               const PolygonWithHoles& frame_polygon, double position_tol_m, double margin_m,
                               double absent_cap_nats, bool read_seams)
    : polygon_(&frame_polygon),
      tol_(position_tol_m),
      margin_(margin_m),
      read_seams_(read_seams),
      absent_cap_(absent_cap_nats) {
  if (seams.empty() || frame_polygon.outer.size() < 3) return;
  const Rect b = bounds_of(frame_polygon);
  cell_ = seams.cell_m;
  const double pad = 0.05;
  x0_ = b.x0 - pad;
  y0_ = b.y0 - pad;
  w_ = static_cast<int>(std::ceil((b.x1 - b.x0 + 2 * pad) / cell_));
  h_ = static_cast<int>(std::ceil((b.y1 - b.y0 + 2 * pad) / cell_));
  if (w_ <= 0 || h_ <= 0 || static_cast<double>(w_) * h_ > 4e6) {
    w_ = h_ = 0;
    return;
  }
  // The raw raster (no line filter) turned into the frame: the likelihood does its own
  // averaging along the predicted lines.
  tape_ = TapeEvidence(seams, frame, x0_, y0_, w_, h_);
  if (!read_seams_) return;
  const cv::Mat dst = seams_in_frame(seams, frame, x0_, y0_, w_, h_);
  integral_into(dst, sat_);
}

double SeamLikelihood::strip_mean(double x0, double y0, double x1, double y1) const {
  const double fx0 = std::clamp((x0 - x0_) / cell_, 0.0, static_cast<double>(w_));
  const double fx1 = std::clamp((x1 - x0_) / cell_, 0.0, static_cast<double>(w_));
  const double fy0 = std::clamp((y0 - y0_) / cell_, 0.0, static_cast<double>(h_));
  const double fy1 = std::clamp((y1 - y0_) / cell_, 0.0, static_cast<double>(h_));
  const double cells = (fx1 - fx0) * (fy1 - fy0);
  if (!(cells > 0)) return 0.0;
  return sat_sum_bilinear(sat_, w_, h_, fx0, fy0, fx1, fy1) / cells;
}

double SeamLikelihood::contrast(const PieceKey& k, double pos) const {
  // On the line: the strongest one-cell strip within the position tolerance (gaps spread the
  // boxes, so a seam lies within a few millimetres of its predicted side). Beside it: the box
  // tops just beyond the tolerance on both sides.
  const double s0 = static_cast<double>(k.index) * kPiece_m, s1 = s0 + kPiece_m;
  auto strip = [&](double a0, double a1) {
    return k.vertical ? strip_mean(a0, s0, a1, s1) : strip_mean(s0, a0, s1, a1);
  };
  double on = 0.0;
  for (double o = -tol_; o <= tol_ + 1e-12; o += cell_) on = std::max(on, strip(pos + o - cell_ / 2, pos + o + cell_ / 2));
  const double b0 = tol_ + 2 * cell_, b1 = b0 + 0.008;
  const double beside = 0.5 * (strip(pos - b1, pos - b0) + strip(pos + b0, pos + b1));
  return on - beside;
}

std::map<SeamLikelihood::PieceKey, double> SeamLikelihood::pieces(const std::vector<FrameBox>& boxes) const {
  std::map<PieceKey, double> out;
  const double m = margin_;
  for (const auto& fb : boxes) {
    for_each_box_side(fb.rect, m, [&](const BoxSide& side) {
      const auto k0 = static_cast<std::int64_t>(std::ceil(side.lo / kPiece_m - 0.5));
      const auto k1 = static_cast<std::int64_t>(std::floor(side.hi / kPiece_m - 0.5));
      const PieceKey probe{side.vertical, static_cast<std::int64_t>(std::llround(side.pos / kKey_m)), 0};
      for (std::int64_t k = k0; k <= k1; ++k) {
        PieceKey key = probe;
        key.index = k;
        if (out.count(key) != 0) continue;
        const double s0 = static_cast<double>(k) * kPiece_m, s1 = s0 + kPiece_m;
        const Rect beyond = side.beyond(s0, s1);
        if (clipped_area(*polygon_, beyond.x0, beyond.y0, beyond.x1, beyond.y1) < 0.5 * beyond.area()) continue;
        out.emplace(key, side.pos);
      }
    });
  }
  return out;
}

bool SeamLikelihood::along_a_side(const std::vector<FrameBox>& boxes, const PieceKey& key) {
  const double mid = (static_cast<double>(key.index) + 0.5) * kPiece_m;
  bool on = false;
  for (const auto& fb : boxes) {
    for_each_box_side(fb.rect, 0.0, [&](const BoxSide& side) {
      on = on || (side.vertical == key.vertical && std::llround(side.pos / kKey_m) == key.pos_key &&
                  mid >= side.lo && mid <= side.hi);
    });
    if (on) return true;
  }
  return false;
}

bool SeamLikelihood::calibrate(const std::vector<const std::vector<FrameBox>*>& candidates) {
  usable_ = false;
  measured_ = false;
  axis_seams_[0] = axis_seams_[1] = 0;
  if (empty() || !read_seams_ || candidates.empty()) return false;
  std::vector<std::map<PieceKey, double>> all;
  for (const auto* c : candidates) all.push_back(pieces(*c));
  // Seam reference: pieces every candidate predicts.
  std::vector<double> seam_c;
  for (const auto& [key, pos] : all.front()) {
    bool common = true;
    for (std::size_t i = 1; i < all.size() && common; ++i) common = all[i].count(key) != 0;
    if (common) {
      seam_c.push_back(contrast(key, pos));
      ++axis_seams_[key.vertical ? 1 : 0];
    }
  }
  // Candidates that share (almost) no seam, as a lone pinwheel and its mirror image: one of them
  // is right, so the strongest 1/k of all their predicted pieces stand for the seams.
  if (seam_c.size() < 4 && candidates.size() > 1) {
    std::map<PieceKey, double> any;
    for (const auto& mp : all) any.insert(mp.begin(), mp.end());
    std::vector<std::pair<double, bool>> by_contrast;  // (contrast, vertical)
    for (const auto& [key, pos] : any) by_contrast.emplace_back(contrast(key, pos), key.vertical);
    std::sort(by_contrast.begin(), by_contrast.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    seam_c.clear();
    axis_seams_[0] = axis_seams_[1] = 0;
    for (std::size_t i = 0; i < by_contrast.size() / candidates.size(); ++i) {
      seam_c.push_back(by_contrast[i].first);
      ++axis_seams_[by_contrast[i].second ? 1 : 0];
    }
  }
  // No-seam reference: lines at a quarter and three quarters across each box of every
  // candidate, away from every predicted seam (a half-box line is a seam in brick patterns).
  std::vector<std::pair<bool, double>> seam_lines;  // (vertical, pos)
  for (const auto& mp : all) {
    for (const auto& [key, pos] : mp) seam_lines.emplace_back(key.vertical, pos);
  }
  std::sort(seam_lines.begin(), seam_lines.end());
  seam_lines.erase(std::unique(seam_lines.begin(), seam_lines.end()), seam_lines.end());
  auto near_seam = [&](bool vertical, double pos) {
    auto it = std::lower_bound(seam_lines.begin(), seam_lines.end(), std::make_pair(vertical, pos - 2 * tol_ - 0.01));
    return it != seam_lines.end() && it->first == vertical && it->second <= pos + 2 * tol_ + 0.01;
  };
  std::vector<double> null_c;
  std::set<PieceKey> seen;
  for (const auto* cand : candidates) {
    for (const auto& fb : *cand) {
      const Rect& r = fb.rect;
      for (int axis = 0; axis < 2; ++axis) {
        const bool vertical = axis == 0;
        for (double f : {0.25, 0.75}) {
          const double pos = vertical ? r.x0 + f * (r.x1 - r.x0) : r.y0 + f * (r.y1 - r.y0);
          if (near_seam(vertical, pos)) continue;
          const double lo = (vertical ? r.y0 : r.x0) + margin_ + tol_, hi = (vertical ? r.y1 : r.x1) - margin_ - tol_;
          const auto k0 = static_cast<std::int64_t>(std::ceil(lo / kPiece_m));
          const auto k1 = static_cast<std::int64_t>(std::floor(hi / kPiece_m)) - 1;
          for (std::int64_t k = k0; k <= k1; ++k) {
            const PieceKey key{vertical, static_cast<std::int64_t>(std::llround(pos / kKey_m)), k};
            if (!seen.insert(key).second) continue;
            null_c.push_back(contrast(key, pos));
          }
        }
      }
    }
  }
  if (seam_c.size() < 4 || null_c.size() < 8) return false;
  measured_ = true;
  mu0_ = upper_median(null_c);
  mu1_ = upper_median(seam_c);
  const double sep = mu1_ - mu0_;
  // Noise floors: a share of the separation keeps a noise-free raster from giving unbounded
  // odds. Clean box tops are exactly 0 in the raster (its depth and dark-line parts start above
  // a noise threshold), so the MAD can vanish: 2 % of a full seam keeps a trace a few cells
  // wide from standing "many sigma" out of them.
  sigma0_ = std::max({mad_sigma(null_c, mu0_), 0.05 * std::abs(sep), kNullSigmaFloor});
  sigma1_ = std::max(mad_sigma(seam_c, mu1_), sigma0_);
  // Seams must stand out of the box tops by several noise levels to decide anything.
  usable_ = sep >= 3.0 * sigma0_;
  return usable_;
}

double SeamLikelihood::decisive_nats(double min_short_m) { return kPieceCap * 0.5 * min_short_m / kPiece_m; }

double SeamLikelihood::llr(double c) const {
  const double x = std::clamp(c, mu0_, mu1_);
  const double z1 = (x - mu1_) / sigma1_, z0 = (x - mu0_) / sigma0_;
  const double v = -0.5 * z1 * z1 - std::log(sigma1_) + 0.5 * z0 * z0 + std::log(sigma0_);
  return std::clamp(v, -kMissingSeamCap, kPieceCap);
}

double SeamLikelihood::llr(double c, bool vertical) const {
  const double v = llr(c);
  return v < 0.0 && axis_seams_[vertical ? 1 : 0] < 2 ? 0.0 : v;
}

double SeamLikelihood::tape_nats(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b) const {
  return tape_splits(a, b) ? 0.0 : kTapeNatsPerM * tape_.compare_m(a, b);
}

double SeamLikelihood::compare(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b,
                               bool with_tape) const {
  const double tape = with_tape ? tape_nats(a, b) : 0.0;
  if (!usable_) return tape;
  const auto pa = pieces(a), pb = pieces(b);
  // Pieces where the layouts disagree, with the sign of the layout that predicts the seam.
  struct Diff {
    PieceKey key;
    double pos;
    int sign;
  };
  std::vector<Diff> diff;
  // A piece near the end of a box side is not read (the corner margin): where the other layout
  // has a box side along the same line there, it predicts that seam too (a box split in two ends
  // its halves where the whole box runs on).
  for (const auto& [k, pos] : pa)
    if (pb.count(k) == 0 && !along_a_side(b, k)) diff.push_back({k, pos, +1});
  for (const auto& [k, pos] : pb)
    if (pa.count(k) == 0 && !along_a_side(a, k)) diff.push_back({k, pos, -1});
  std::sort(diff.begin(), diff.end(), [](const Diff& x, const Diff& y) { return x.key < y.key; });
  double d = 0.0, absent = 0.0;
  for (std::size_t i = 0; i < diff.size();) {
    std::size_t j = i + 1;
    while (j < diff.size() && diff[j].sign == diff[i].sign && diff[j].key.vertical == diff[i].key.vertical &&
           diff[j].key.pos_key == diff[i].key.pos_key && diff[j].key.index == diff[j - 1].key.index + 1) {
      ++j;
    }
    std::vector<double> v;
    for (std::size_t t = i; t < j; ++t) v.push_back(llr(contrast(diff[t].key, diff[t].pos), diff[t].key.vertical));
    const double run = diff[i].sign * static_cast<double>(j - i) * upper_median(std::move(v));
    // Runs whose predicted seam is absent (evidence against the layout predicting it) add up
    // apart: together they are capped (absent_cap_nats).
    if (diff[i].sign * run < 0) {
      absent += run;
    } else {
      d += run;
    }
    i = j;
  }
  return d + std::clamp(absent, -absent_cap_, absent_cap_) + tape;
}

}  // namespace palletd::layout_detail
