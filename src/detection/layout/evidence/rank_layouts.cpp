// Near-equal candidate layouts ranked by the seams; footprint moves settled (rank_layouts.hpp).
#include "evidence/rank_layouts.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "palletd/core/statistics.hpp"

#include "evidence/seam_likelihood.hpp"

namespace palletd::layout_detail {

namespace {

/// Two hypotheses whose seam agreement differs by less than this share of the shortest box
/// side [m of seam line] are not separated by the seams (-> ambiguous).
constexpr double kSeamSeparation = 0.3;
/// Seam agreement is read in pieces of this length along a line [m].
constexpr double kAgreementPiece_m = 0.04;

/// Median of the seam values of kAgreementPiece_m pieces along a line [0, 1]; `value(piece)`
/// reads a piece and returns a negative value where the piece is not part of the seam line.
template <typename ValueFn>
double median_along(double lo, double hi, ValueFn&& value) {
  const int n = std::max(1, static_cast<int>(std::lround((hi - lo) / kAgreementPiece_m)));
  const double step = (hi - lo) / n;
  std::vector<double> v;
  for (int k = 0; k < n; ++k) {
    const double x = value(lo + k * step, lo + (k + 1) * step);
    if (x >= 0.0) v.push_back(x);
  }
  return upper_median(std::move(v));
}

/// Length of the strongest seam line across the box interior (shrunk by margin_m), weighted by
/// the median seam value along it [m].
double interior_crossing_m(const Rect& r, const SeamTable& table, double margin_m) {
  const double m = margin_m;
  const double cell = table.cell();
  const double lx = r.x1 - r.x0 - 2 * m, ly = r.y1 - r.y0 - 2 * m;
  if (lx <= 0 || ly <= 0) return 0.0;
  double crossing = 0.0;
  for (double y = r.y0 + m; y + cell <= r.y1 - m; y += cell) {
    crossing = std::max(crossing, lx * median_along(r.x0 + m, r.x1 - m, [&](double s0, double s1) {
                                    return table.mean({s0, y, s1, y + cell});
                                  }));
  }
  for (double x = r.x0 + m; x + cell <= r.x1 - m; x += cell) {
    crossing = std::max(crossing, ly * median_along(r.y0 + m, r.y1 - m, [&](double s0, double s1) {
                                    return table.mean({x, s0, x + cell, s1});
                                  }));
  }
  return crossing;
}

/// How well a frame layout agrees with the seam lines [m]: the length of box edges shared with
/// a neighbour, each weighted by the median seam support along the whole edge, minus the
/// length of the strongest seam line across each box interior, weighted by the median along
/// it. Medians over whole edges and widths make short edges inside boxes (tape, labels) and
/// scattered dropouts weigh nothing against a seam along a full box edge.
double seam_agreement(const std::vector<FrameBox>& boxes, const SeamTable& table,
                      const PolygonWithHoles& frame_polygon, const LayoutParams& params) {
  const double cell = table.cell();
  auto layer_area = [&](const Rect& q) { return clipped_area(frame_polygon, q.x0, q.y0, q.x1, q.y1); };
  double agree = 0.0;
  for (const auto& fb : boxes) {
    for_each_box_side(fb.rect, params.seams.margin_m, [&](const BoxSide& side) {
      double shared = 0.0;
      const double med = median_along(side.lo, side.hi, [&](double s0, double s1) {
        const Rect beyond = side.beyond(s0, s1);
        if (layer_area(beyond) < 0.5 * beyond.area()) return -1.0;  // no neighbour there
        shared += s1 - s0;
        return std::min(1.0, 2.0 * table.support(side.line(s0, s1, cell)));
      });
      agree += shared * med;
    });
    agree -= interior_crossing_m(fb.rect, table, params.seams.margin_m);
  }
  return agree;
}

/// Ranking by the seam likelihood among near-equal layouts of one layout frame (the usual
/// case): the pieces where two layouts disagree decide, against noise levels taken from the
/// frame. Sets `seams_invisible` when the seams were measured and do not stand out of the box
/// tops. Empty order when it cannot decide.
Ranking rank_by_likelihood(const std::vector<Candidate>& cands, const std::vector<std::size_t>& near,
                           ComponentFrames& frames, const SeamJudge& judge, const LayoutParams& params,
                           bool& seams_invisible) {
  const std::size_t slot = cands[near.front()].orientation;
  for (std::size_t n : near) {
    if (cands[n].orientation != slot) return {};
  }
  SeamLikelihood& lik = *frames.likelihood(slot, judge, params.seams.margin_m);
  std::vector<const std::vector<FrameBox>*> layouts;
  for (std::size_t n : near) layouts.push_back(&cands[n].boxes);
  const bool seams_usable = lik.calibrate(layouts);
  if (!seams_usable) {
    seams_invisible = lik.measured();
    if (!lik.reads_tape()) return {};
  }
  // Evidence of each against the outline's best, then the winner against every other.
  std::vector<double> ev(near.size(), 0.0);
  for (std::size_t i = 1; i < near.size(); ++i)
    ev[i] = lik.compare(cands[near[i]].boxes, cands[near[0]].boxes);
  const auto w = static_cast<std::size_t>(std::max_element(ev.begin(), ev.end()) - ev.begin());
  double margin_nats = 1e300, seams_margin_nats = 1e300;
  for (std::size_t i = 0; i < near.size(); ++i) {
    if (i == w) continue;
    margin_nats = std::min(margin_nats, lik.compare(cands[near[w]].boxes, cands[near[i]].boxes));
    seams_margin_nats =
        std::min(seams_margin_nats, lik.compare(cands[near[w]].boxes, cands[near[i]].boxes, false));
  }
  const double decisive = SeamLikelihood::decisive_nats(judge.min_short_m);
  // Tape decides among the candidates only where the winner explains every band the layer
  // shows as long as a carton's tape: the right layout may be none of them.
  if (seams_margin_nats < decisive && margin_nats >= decisive &&
      lik.unexplained_band_m(cands[near[w]].boxes, judge.min_long_m) > 0.0)
    margin_nats = seams_margin_nats;
  if (!seams_usable && margin_nats < decisive) return {};  // the tape alone did not decide either
  Ranking r;
  r.order.push_back(near[w]);
  for (std::size_t i = 0; i < near.size(); ++i)
    if (i != w) r.order.push_back(near[i]);
  r.ambiguous = margin_nats < decisive;
  return r;
}

/// Ranking by the seam agreement (line integrals along whole edges): a best guess where the
/// likelihood cannot decide; ambiguous unless the first is clearly ahead.
Ranking rank_by_agreement(const std::vector<Candidate>& cands, const std::vector<std::size_t>& near,
                          ComponentFrames& frames, const SeamJudge& judge, const LayoutParams& params,
                          bool seams_invisible) {
  std::vector<double> agree(cands.size(), 0.0);
  for (std::size_t n : near) {
    const std::size_t slot = cands[n].orientation;
    const SeamTable* t = frames.table(slot, judge.seams);
    agree[n] = t == nullptr ? 0.0 : seam_agreement(cands[n].boxes, *t, frames.polygon(slot), params);
  }
  Ranking r{near, false};
  std::stable_sort(r.order.begin(), r.order.end(),
                   [&](std::size_t a, std::size_t b) { return agree[a] > agree[b]; });
  r.ambiguous =
      seams_invisible || agree[r.order[0]] - agree[r.order[1]] < kSeamSeparation * judge.min_short_m;
  return r;
}

}  // namespace

std::size_t ComponentFrames::add(const LayoutFrame& frame, PolygonWithHoles frame_polygon) {
  frames_.push_back(frame);
  polygons_.push_back(std::move(frame_polygon));
  tables_.emplace_back();
  likelihoods_.emplace_back();
  return frames_.size() - 1;
}

SeamLikelihood* ComponentFrames::likelihood(std::size_t i, const SeamJudge& judge, double margin_m) {
  const SeamEvidence* raster = judge.seams != nullptr ? judge.seams : judge.tape;
  if (raster == nullptr) return nullptr;
  if (!likelihoods_[i]) {
    likelihoods_[i] =
        std::make_unique<SeamLikelihood>(*raster, frames_[i], polygons_[i], judge.merge_tol_m, margin_m,
                                         judge.absent_cap_nats, judge.seams != nullptr);
  }
  return likelihoods_[i].get();
}

const SeamTable* ComponentFrames::table(std::size_t i, const SeamEvidence* seams) {
  if (seams == nullptr) return nullptr;
  if (tables_[i].empty()) tables_[i] = SeamTable(*seams, frames_[i], bounds_of(polygons_[i]));
  return tables_[i].empty() ? nullptr : &tables_[i];
}

std::vector<std::size_t> near_equal_candidates(const std::vector<Candidate>& sorted, double tie_margin_m2,
                                               double same_tol_m) {
  std::vector<std::size_t> near{0};
  for (std::size_t k = 1; k < sorted.size(); ++k) {
    const Candidate& c = sorted[k];
    if (sorted.front().score - c.score >= tie_margin_m2) break;
    bool dup = false;
    for (std::size_t n : near) {
      const Candidate& o = sorted[n];
      dup = dup || (std::abs(c.frame.theta_rad - o.frame.theta_rad) < 1e-9 &&
                    same_layout(c.boxes, o.boxes, same_tol_m));
    }
    if (!dup) near.push_back(k);
  }
  return near;
}

Ranking rank_by_seams(const std::vector<Candidate>& cands, const std::vector<std::size_t>& near,
                      ComponentFrames& frames, const SeamJudge& judge, const LayoutParams& params) {
  if (near.size() < 2) return {near, false};
  if (judge.seams == nullptr && judge.tape == nullptr) return {near, true};
  bool seams_invisible = false;
  Ranking r = rank_by_likelihood(cands, near, frames, judge, params, seams_invisible);
  if (!r.order.empty()) return r;
  return rank_by_agreement(cands, near, frames, judge, params, seams_invisible);
}

bool settle_footprint_moves(Candidate& best, const std::vector<Candidate>& cands,
                            const std::vector<std::size_t>& near, ComponentFrames& frames,
                            const std::vector<BoxFormat>& formats, const SeamJudge& judge,
                            const LayoutParams& params) {
  const double slack_m = 2.0 * kMaxCartonGap_m + judge.merge_tol_m;
  const std::vector<FootprintMove> moves = footprint_moves(best.boxes, formats, judge.merge_tol_m);
  const std::vector<FootprintMove> splits = judge.seams != nullptr
                                                ? split_moves(best.boxes, formats, judge.merge_tol_m, slack_m)
                                                : std::vector<FootprintMove>{};
  if (moves.empty() && splits.empty()) return false;
  SeamLikelihood* lik = frames.likelihood(best.orientation, judge, params.seams.margin_m);
  if (lik != nullptr) {
    const std::vector<FrameBox> overlay = moves_overlay(best.boxes, moves);
    const std::vector<FrameBox> split_overlay = moves_overlay(best.boxes, splits);
    std::vector<const std::vector<FrameBox>*> calibration{&best.boxes, &overlay};
    if (!splits.empty()) calibration.push_back(&split_overlay);
    for (std::size_t n : near) {
      if (cands[n].orientation == best.orientation) calibration.push_back(&cands[n].boxes);
    }
    lik->calibrate(calibration);
  }
  const RetileResult rr = retile_by_seams(&best.boxes, formats, lik, judge.merge_tol_m, slack_m,
                                          SeamLikelihood::decisive_nats(judge.min_short_m));
  return rr.tied;
}

Ranking settle_then_rank(std::vector<Candidate>& cands, const std::vector<std::size_t>& near, Ranking ranking,
                         ComponentFrames& frames, const std::vector<BoxFormat>& formats,
                         const SeamJudge& judge, const LayoutParams& params, double same_tol_m) {
  std::vector<Candidate> settled;
  std::vector<bool> tied(cands.size(), false);
  for (std::size_t n : near) {
    settled.push_back(cands[n]);
    tied[n] = settle_footprint_moves(settled.back(), cands, near, frames, formats, judge, params);
  }
  std::vector<std::size_t> kept;
  bool moved = false;
  for (std::size_t i = 0; i < near.size(); ++i) {
    moved = moved || !same_layout(settled[i].boxes, cands[near[i]].boxes, 1e-9);
    bool dup = false;
    for (std::size_t k : kept) {
      dup = dup || (std::abs(cands[k].frame.theta_rad - settled[i].frame.theta_rad) < 1e-9 &&
                    same_layout(cands[k].boxes, settled[i].boxes, same_tol_m));
    }
    cands[near[i]] = std::move(settled[i]);
    if (!dup) kept.push_back(near[i]);
  }
  if (!moved) return ranking;  // as ranked before: in doubt
  ranking = rank_by_seams(cands, kept, frames, judge, params);
  // Only layouts that all settle into one are no tie: where several stay different, the seams
  // that ranked them apart before could not, and a ranking of the settled ones again rests on
  // splits placed where a slack layer's real seams happen to lie.
  ranking.ambiguous = kept.size() > 1 || tied[ranking.order.front()];
  return ranking;
}

}  // namespace palletd::layout_detail
