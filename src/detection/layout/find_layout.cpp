// find_layout(): input checks, the search budget, and per component the named phases: search
// each layout orientation, rank the near-equal layouts by the seams, settle footprint moves,
// complete boxes where the depth ends, flag what the boxes leave unexplained.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "palletd/core/timing.hpp"

#include "evidence/layout_scoring.hpp"
#include "evidence/rank_layouts.hpp"
#include "evidence/seam_likelihood.hpp"
#include "layout_internal.hpp"

namespace palletd {

using namespace layout_detail;

namespace {

using Clock = std::chrono::steady_clock;

constexpr double kSimplify_m = 0.004;        ///< outline simplification for corners and lines [m]
constexpr std::size_t kMaxOrientations = 3;  ///< layout orientations searched per component
/// Seams predicted and absent count together for at most this share of the decisive evidence:
/// alone they never decide (a gap can be pressed shut), a seam that shows must.
constexpr double kAbsentShare = 0.9;
/// Two layouts are the same when every box has a twin closer than this share of the square root
/// of the smallest box area.
constexpr double kSameLayoutShare = 0.25;
/// Uncovered pieces narrower than this are gaps between boxes, not unexplained layer [m].
constexpr double kUncoveredGap_m = 0.02;
/// A search again after completing unseen boxes may take this share of the call's expansions
/// beyond what is left of the component's part.
constexpr std::size_t kResearchShareDivisor = 10;

Eigen::Vector2d centroid_of(const Ring2d& ring) {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const auto& p : ring) c += p;
  return ring.empty() ? c : Eigen::Vector2d(c / static_cast<double>(ring.size()));
}

/// What every component's phases share: the recipe's figures, the seams and surroundings.
struct LayoutContext {
  const std::vector<BoxFormat>& formats;
  const LayoutParams& params;
  const LayerSurroundings* surroundings = nullptr;  ///< null when there are none to complete into
  SearchMemory* memory = nullptr;                   ///< the searches' reused memory; null = their own
  FormatExtremes extremes;
  double min_edge_m = 0.0;     ///< outline edges shorter than this carry no corner
  double tie_margin_m2 = 0.0;  ///< outline scores closer than this are near-equal
  SeamJudge judge;
};

LayoutContext make_context(const std::vector<BoxFormat>& formats, const LayoutParams& params,
                           const SeamEvidence* seams, const LayerSurroundings* surroundings,
                           SearchMemory* memory) {
  LayoutContext ctx{formats, params, nullptr, memory, format_extremes(formats), 0.0, 0.0, {}};
  ctx.min_edge_m = min_corner_edge_m(ctx.extremes.min_short_m);
  ctx.tie_margin_m2 = tie_margin_m2(params, formats);
  const bool have_seams = seams != nullptr && !seams->empty() && seams->strength > 0.0;
  ctx.judge.seams = have_seams ? seams : nullptr;
  ctx.judge.tape = !have_seams && seams != nullptr && !seams->tops.empty() ? seams : nullptr;
  ctx.judge.min_short_m = ctx.extremes.min_short_m;
  ctx.judge.min_long_m = ctx.extremes.min_long_m;
  ctx.judge.merge_tol_m = line_merge_tol_m(params, ctx.extremes.min_short_m);
  ctx.judge.absent_cap_nats = kAbsentShare * SeamLikelihood::decisive_nats(ctx.extremes.min_short_m);
  const bool can_complete = surroundings != nullptr && !surroundings->empty() &&
                            params.completion.unseen_min_fraction > 0.0 &&
                            params.search.mode == SearchMode::kBestFirst;
  ctx.surroundings = can_complete ? surroundings : nullptr;
  return ctx;
}

/// The call's search budget, shared in a fixed way so that the same frame gives the same layout
/// whatever the machine load: each component gets an equal part of what is left, within it the
/// best supported orientation 3/4 of what is left and the last orientation the rest. Expansions
/// are the budget; the wall-clock deadline is a safety cap shared the same way.
class BudgetSplit {
 public:
  BudgetSplit(std::size_t expansions, Clock::time_point end) : call_left_(expansions), call_end_(end) {}

  /// Starts a component's part: 1 / components_left of what the call has left.
  void begin_component(std::size_t components_left) {
    component_ = {call_left_ / components_left, share_until(call_end_, 1, components_left)};
  }
  /// Starts orientation `index` of `count`: 3/4 of what the component has left, the last all.
  SearchBudget begin_orientation(std::size_t index, std::size_t count) {
    const bool last = index + 1 == count;
    orientation_ = {last ? component_.expansions : component_.expansions * 3 / 4,
                    share_until(component_.deadline.end, last ? 1 : 3, last ? 1 : 4)};
    return orientation_;
  }
  /// What the current orientation has left.
  [[nodiscard]] const SearchBudget& orientation_left() const { return orientation_; }
  /// A search again after completion: what the component has left, at least `floor`.
  [[nodiscard]] SearchBudget research(std::size_t floor) const {
    return {std::max(component_.expansions, floor), component_.deadline};
  }
  /// Books expansions used by a search of the current orientation.
  void spend(std::size_t used) {
    used = std::min(used, orientation_.expansions);
    orientation_.expansions -= used;
    component_.expansions -= std::min(used, component_.expansions);
    call_left_ -= std::min(used, call_left_);
  }
  /// Books expansions used beyond the orientations' parts (the search again after completion).
  void spend_call(std::size_t used) { call_left_ -= std::min(used, call_left_); }
  [[nodiscard]] const Deadline& component_deadline() const { return component_.deadline; }
  /// The whole call's safety cap.
  [[nodiscard]] Deadline call_deadline() const { return Deadline{call_end_}; }

 private:
  /// now + (end - now) * num / den, or now when end has passed.
  static Deadline share_until(Clock::time_point end, std::size_t num, std::size_t den) {
    const auto now = Clock::now();
    const auto left = end > now ? end - now : Clock::duration::zero();
    return Deadline{now + left * static_cast<long>(num) / static_cast<long>(den)};
  }

  std::size_t call_left_;
  Clock::time_point call_end_;
  SearchBudget component_;
  SearchBudget orientation_;
};

/// Adds a search's counters to the result; `clock`: the wall-clock cap ended it.
void tally(LayoutResult& result, std::size_t visited, bool exhausted, bool clock) {
  result.hypotheses_visited += visited;
  result.budget_exhausted = result.budget_exhausted || exhausted;
  result.clock_ran_out = result.clock_ran_out || (exhausted && clock);
}

/// Whether a component is too small for any box (its outline grown by the best-first search's
/// tolerance, against the share a box needs: a_min, or unseen_min where boxes may be completed).
bool too_small_for_boxes(const PolygonWithHoles& comp, double comp_area_m2, const LayoutContext& ctx) {
  const LayoutParams& p = ctx.params;
  double grown_area = comp_area_m2;
  if (p.search.mode == SearchMode::kBestFirst && p.search.outline_tolerance_m > 0.0) {
    grown_area += p.search.outline_tolerance_m * rings_length_m(comp) +
                  4.0 * p.search.outline_tolerance_m * p.search.outline_tolerance_m;
  }
  const double share =
      ctx.surroundings != nullptr ? p.completion.unseen_min_fraction : p.search.a_min_fraction;
  return grown_area < share * ctx.extremes.min_area_m2;
}

/// The paper's search (Algorithms 1-3) on one component; false with `reason` when nothing fits.
bool solve_paper_component(const PolygonWithHoles& comp, const PolygonWithHoles& comp_edges, std::size_t ci,
                           const LayoutContext& ctx, const Deadline& deadline, LayoutResult& result,
                           double& covered_m2, std::string& reason) {
  const PaperSolution ps = search_paper(comp, comp_edges, ctx.formats, ctx.params, deadline);
  tally(result, ps.visited, ps.cap_hit, ps.clock_ran_out);
  if (!ps.found) {
    reason = orthogonal_corners(comp_edges, ctx.params.search.corner_angle_tol_deg, ctx.min_edge_m).empty()
                 ? " has no orthogonal corner (round or damaged outline)"
                 : ": no box of the recipe fits its outline";
    return false;
  }
  result.score += ps.score;
  for (const auto& b : ps.boxes) {
    const BoxSupport s = box_support(b, comp, nullptr, ctx.params);
    result.boxes.push_back({b, s.score, static_cast<int>(ci), false, {}});
    set_support_terms(s, result.boxes.back().evidence);
    covered_m2 += s.inside_area_m2;
  }
  return true;
}

/// Too many near-equal tilings to list, or so many that the outline-only search ran out among
/// them: a seam-penalised search chooses among the layouts whose outline score is within the tie
/// margin of the best found (never fewer boxes); its layouts join the candidates with their outline
/// scores. Returns whether it completed.
bool research_with_seams(const PolygonWithHoles& fp, const PolygonWithHoles& fe, const LayoutFrame& frame,
                         std::size_t slot, double best_score, const LayoutContext& ctx, BudgetSplit& budget,
                         LayoutResult& result, std::vector<Candidate>& cands) {
  const SeamTable table(*ctx.judge.seams, frame, bounds_of(fp));
  if (table.empty()) return false;
  // After an outline-only search that ran out, what the orientation has left may be nothing: the
  // search again after completion's floor applies.
  const bool spent = budget.orientation_left().expansions == 0;
  const SearchBudget share =
      spent ? budget.research(ctx.params.search.search_expansions / kResearchShareDivisor)
            : budget.orientation_left();
  const ComponentSolution ss = search_best_first(fp, fe, ctx.formats, ctx.params, &table, share,
                                                 best_score - ctx.tie_margin_m2, {}, ctx.memory);
  result.search_expansions += ss.expansions;
  if (spent) {
    budget.spend_call(ss.expansions);
  } else {
    budget.spend(ss.expansions);
  }
  tally(result, ss.visited, ss.budget_exhausted, ss.clock_ran_out);
  if (ss.found) cands.push_back({frame, ss.boxes, ss.outline_score, slot});
  for (const auto& alt : ss.alternatives) {
    double covered_m2 = 0.0;  // its outline score
    for (const auto& b : alt) covered_m2 += clipped_area(fp, b.rect.x0, b.rect.y0, b.rect.x1, b.rect.y1);
    cands.push_back({frame, alt, covered_m2, slot});
  }
  return !ss.budget_exhausted;
}

/// The best-first search in each of the component's best supported layout orientations: the
/// outline alone decides coverage (a noisy seam raster must not veto a layout the outline
/// supports); the seams rank the near-equal candidates afterwards.
std::vector<Candidate> search_orientations(const PolygonWithHoles& comp, const PolygonWithHoles& comp_edges,
                                           const std::vector<double>& thetas, const LayoutContext& ctx,
                                           BudgetSplit& budget, LayoutResult& result, ComponentFrames& frames,
                                           std::string& why) {
  std::vector<Candidate> cands;
  const std::size_t n_orient = std::min(thetas.size(), kMaxOrientations);
  for (std::size_t oi = 0; oi < n_orient; ++oi) {
    const SearchBudget share = budget.begin_orientation(oi, n_orient);
    LayoutFrame frame;
    frame.theta_rad = thetas[oi];
    frame.pivot = centroid_of(comp.outer);
    const PolygonWithHoles fe = frame.to_frame(comp_edges);
    const std::size_t slot = frames.add(frame, frame.to_frame(comp));
    const PolygonWithHoles& fp = frames.polygon(slot);
    const ComponentSolution cs =
        search_best_first(fp, fe, ctx.formats, ctx.params, nullptr, share, -1e300, {}, ctx.memory);
    result.search_expansions += cs.expansions;
    budget.spend(cs.expansions);
    if (!cs.found) {
      tally(result, cs.visited, cs.budget_exhausted, cs.clock_ran_out);
      why = cs.reason;
      continue;
    }
    cands.push_back({frame, cs.boxes, cs.score, slot});
    for (std::size_t a = 0; a < cs.alternatives.size(); ++a) {
      cands.push_back({frame, cs.alternatives[a], cs.alternative_scores[a], slot});
    }
    // Layouts the outline cannot tell apart: the six near-equal ones found, or so many that the
    // search ran out among them. The seams search the layouts within the margin of the best
    // coverage found; when that search completes, nothing within it is left unexamined.
    bool exhausted = cs.budget_exhausted;
    const bool outline_tied = cs.alternatives.size() >= kMaxAlternatives || cs.budget_exhausted;
    if (outline_tied && ctx.judge.seams != nullptr &&
        research_with_seams(fp, fe, frame, slot, cs.score, ctx, budget, result, cands)) {
      exhausted = false;
    }
    tally(result, cs.visited, exhausted, cs.clock_ran_out);
  }
  return cands;
}

/// The chosen layout of a component and how sure the phases are of it.
struct ComponentLayout {
  Candidate best;
  bool ambiguous = false;
  LayoutDoubts doubts;         ///< why `ambiguous` is set
  bool all_completed = false;  ///< every box was completed where the depth ends
  std::size_t completed = 0;   ///< else: the last `completed` boxes were
  const Candidate* runner_up = nullptr;
};

/// Nothing the outline alone supports: perhaps boxes it cuts where the depth ends.
bool complete_from_nothing(const PolygonWithHoles& comp_edges, const ComponentFrames& frames,
                           const LayoutContext& ctx, const Deadline& deadline, LayoutResult& result,
                           std::vector<Candidate>& cands, bool& tied) {
  const UnseenCompletion uc =
      complete_unseen({}, frames.polygon(0), frames.frame(0).to_frame(comp_edges), frames.frame(0),
                      ctx.formats, *ctx.surroundings, ctx.params, deadline);
  tally(result, 0, uc.timed_out, uc.timed_out);
  if (uc.added == 0) return false;
  cands.push_back({frames.frame(0), uc.boxes, 0.0, 0});
  tied = uc.tied || uc.open || uc.timed_out;
  result.completed_unseen += uc.added;
  return true;
}

/// Completes the chosen layout with the boxes the outline cuts where the depth ends (a search
/// again when part of the outline is unseen, kResearchShareDivisor of the call's budget at least).
void complete_unseen_boxes(ComponentLayout& chosen, const PolygonWithHoles& comp_edges,
                           const ComponentFrames& frames, const LayoutContext& ctx, BudgetSplit& budget,
                           LayoutResult& result) {
  Candidate& best = chosen.best;
  const SearchBudget research = budget.research(ctx.params.search.search_expansions / kResearchShareDivisor);
  const UnseenCompletion uc = complete_unseen(
      best.boxes, frames.polygon(best.orientation), best.frame.to_frame(comp_edges), best.frame, ctx.formats,
      *ctx.surroundings, ctx.params, budget.call_deadline(), &research);
  result.search_expansions += uc.expansions;
  budget.spend_call(uc.expansions);
  tally(result, 0, uc.timed_out, uc.timed_out);
  best.boxes = uc.boxes;
  chosen.completed = uc.added;
  const bool in_doubt = uc.tied || uc.open || uc.timed_out;
  chosen.ambiguous = chosen.ambiguous || in_doubt;
  chosen.doubts.completion = chosen.doubts.completion || in_doubt;
  result.completed_unseen += uc.added;
}

/// Searches, ranks and completes one component's layout; false with `why` when none is found.
bool choose_layout(const PolygonWithHoles& comp, const PolygonWithHoles& comp_edges, const LayoutContext& ctx,
                   BudgetSplit& budget, LayoutResult& result, ComponentFrames& frames,
                   std::vector<Candidate>& cands, ComponentLayout& chosen, std::string& why) {
  const std::vector<double> thetas =
      layout_orientations(comp_edges, ctx.params.search.corner_angle_tol_deg, ctx.min_edge_m);
  if (thetas.empty()) {
    why = " has no orthogonal corner (round or damaged outline)";
    return false;
  }
  cands = search_orientations(comp, comp_edges, thetas, ctx, budget, result, frames, why);
  bool completion_tied = false;
  if (cands.empty() && ctx.surroundings != nullptr && !frames.empty()) {
    chosen.all_completed = complete_from_nothing(comp_edges, frames, ctx, budget.call_deadline(), result,
                                                 cands, completion_tied);
  }
  if (cands.empty()) {
    why = ": " + (why.empty() ? std::string("no layout found") : why);
    return false;
  }
  std::stable_sort(cands.begin(), cands.end(),
                   [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  const double same_tol_m = kSameLayoutShare * std::sqrt(ctx.extremes.min_area_m2);
  const std::vector<std::size_t> near = near_equal_candidates(cands, ctx.tie_margin_m2, same_tol_m);
  Ranking ranking = rank_by_seams(cands, near, frames, ctx.judge, ctx.params);
  bool moves_tied = false;
  if (ranking.ambiguous) {
    ranking = settle_then_rank(cands, near, ranking, frames, ctx.formats, ctx.judge, ctx.params, same_tol_m);
    chosen.best = cands[ranking.order.front()];
  } else {
    chosen.best = cands[ranking.order.front()];
    moves_tied = settle_footprint_moves(chosen.best, cands, near, frames, ctx.formats, ctx.judge, ctx.params);
  }
  chosen.runner_up = ranking.order.size() > 1 ? &cands[ranking.order[1]] : nullptr;
  chosen.ambiguous = ranking.ambiguous || moves_tied || completion_tied;
  chosen.doubts = {ranking.ambiguous, moves_tied, completion_tied, false};
  if (ctx.surroundings != nullptr && !chosen.all_completed) {
    complete_unseen_boxes(chosen, comp_edges, frames, ctx, budget, result);
  }
  // A piece of the layer that no box covers and that is more than a gap: the outline is not
  // explained, so the layout is in doubt there (a box of another format, or the wrong tiling).
  if (ctx.params.completion.uncovered_flag_fraction > 0.0 &&
      largest_uncovered_m2(frames.polygon(chosen.best.orientation), chosen.best.boxes, kUncoveredGap_m) >=
          ctx.params.completion.uncovered_flag_fraction * ctx.extremes.min_area_m2) {
    chosen.ambiguous = true;
    chosen.doubts.uncovered = true;
  }
  return true;
}

/// Keeps the closest different layout of any component as the result's runner-up.
void record_runner_up(const Candidate& best, const Candidate& other, const std::vector<BoxFormat>& formats,
                      std::size_t ci, LayoutResult& result) {
  const double gap = std::abs(best.score - other.score);
  if (result.runner_up_gap >= 0 && gap >= result.runner_up_gap) return;
  result.runner_up_gap = gap;
  result.runner_up_component = static_cast<int>(ci);
  result.runner_up.clear();
  for (const auto& b : other.boxes) result.runner_up.push_back(other.frame.to_layer(b, formats));
}

/// Scores the chosen boxes against the component and adds them to the result; false with `why`
/// when they cover too little of it (its boxes match no recipe format).
bool publish_layout(const ComponentLayout& chosen, double comp_area_m2, std::size_t ci,
                    ComponentFrames& frames, const LayoutContext& ctx, LayoutResult& result,
                    double& covered_m2, std::string& why) {
  const Candidate& best = chosen.best;
  double comp_covered = 0;
  std::vector<BoxSupport> support;
  const SeamTable* table = frames.table(best.orientation, ctx.judge.seams);
  for (const auto& fb : best.boxes) {
    support.push_back(box_support(best.frame.to_layer(fb, ctx.formats), best.frame,
                                  frames.polygon(best.orientation), table, ctx.params));
    comp_covered += support.back().inside_area_m2;
  }
  if (comp_covered < ctx.params.search.min_coverage * comp_area_m2) {
    why = ": boxes of the recipe cover only " +
          std::to_string(static_cast<int>(100.0 * comp_covered / comp_area_m2)) +
          "% of it (its boxes match no recipe format)";
    return false;
  }
  covered_m2 += comp_covered;
  for (std::size_t k = 0; k < best.boxes.size(); ++k) {
    const bool partly_unseen = chosen.all_completed || k + chosen.completed >= best.boxes.size();
    result.boxes.push_back({best.frame.to_layer(best.boxes[k], ctx.formats), support[k].score,
                            static_cast<int>(ci), partly_unseen, {}});
    set_support_terms(support[k], result.boxes.back().evidence);
  }
  return true;
}

/// One component, best-first search: choose, record, publish. False with `why` (the sentence after
/// "component N") when it gets no layout.
bool solve_best_first_component(const PolygonWithHoles& comp, const PolygonWithHoles& comp_edges,
                                double comp_area_m2, std::size_t ci, const LayoutContext& ctx,
                                BudgetSplit& budget, LayoutResult& result, double& covered_m2,
                                std::string& why) {
  ComponentFrames frames;
  std::vector<Candidate> cands;
  ComponentLayout chosen;
  if (!choose_layout(comp, comp_edges, ctx, budget, result, frames, cands, chosen, why)) return false;
  result.score += chosen.best.score;
  result.ambiguous = result.ambiguous || chosen.ambiguous;
  LayoutDoubts& d = result.doubts;
  d = {d.tied_layouts || chosen.doubts.tied_layouts, d.undecided_formats || chosen.doubts.undecided_formats,
       d.completion || chosen.doubts.completion, d.uncovered || chosen.doubts.uncovered};
  if (chosen.runner_up != nullptr) record_runner_up(chosen.best, *chosen.runner_up, ctx.formats, ci, result);
  return publish_layout(chosen, comp_area_m2, ci, frames, ctx, result, covered_m2, why);
}

/// Status and reason from the boxes found and the components' reasons. No layout from a search its
/// budget ended says so first: the boxes it had were not shown not to fit.
void finish_status(const std::vector<std::string>& reasons, LayoutResult& result) {
  std::string r;
  for (const auto& s : reasons) r += (r.empty() ? "" : "; ") + s;
  result.status = result.boxes.empty() ? DetectionStatus::kNoLayout : DetectionStatus::kOk;
  result.reason = result.boxes.empty() && r.empty() ? "no layout found" : r;
  if (result.boxes.empty() && result.budget_exhausted)
    result.reason =
        "the search's budget (detection.layout.time_budget_ms or search_expansions) ran out before it "
        "found a layout: " +
        result.reason;
}

}  // namespace

std::string box_formats_problem(const std::vector<BoxFormat>& formats) {
  if (formats.empty()) return "the recipe lists no box format";
  for (std::size_t i = 0; i < formats.size(); ++i) {
    const auto& f = formats[i];
    if (!std::isfinite(f.long_m) || !std::isfinite(f.short_m) || f.long_m <= 0.0 || f.short_m <= 0.0) {
      std::ostringstream s;
      s << "box format " << i << " (" << f.name << ") has a zero, negative or invalid size";
      return s.str();
    }
    if (f.short_m > f.long_m + 1e-9) {
      std::ostringstream s;
      s << "box format " << i << " (" << f.name << ") lists its short side first";
      return s.str();
    }
  }
  return {};
}

namespace {

/// find_layout() on formats of distinct sizes.
LayoutResult find_distinct_layout(const std::vector<PolygonWithHoles>& components,
                                  const std::vector<BoxFormat>& formats, const LayoutParams& params,
                                  const SeamEvidence* seams, const LayerSurroundings* surroundings,
                                  SearchMemory* memory) {
  const auto t0 = Clock::now();
  LayoutResult result;
  if (components.empty()) {
    result.reason = "the layer has no outline";
  } else {
    const LayoutContext ctx = make_context(formats, params, seams, surroundings, memory);
    const auto budget_ms =
        std::chrono::duration<double, std::milli>(std::max(0.0, params.search.time_budget_ms));
    BudgetSplit budget(params.search.search_expansions,
                       t0 + std::chrono::duration_cast<Clock::duration>(budget_ms));
    double total_area = 0.0, covered = 0.0;
    std::vector<std::string> reasons;
    for (std::size_t ci = 0; ci < components.size(); ++ci) {
      const PolygonWithHoles& comp = components[ci];
      const double comp_area = area(comp);
      total_area += comp_area;
      std::string why;
      if (comp.outer.size() < 3 || !(comp_area > 0.0)) {
        why = " has no area";
      } else if (too_small_for_boxes(comp, comp_area, ctx)) {
        why = " is smaller than every box format";
      } else {
        budget.begin_component(components.size() - ci);
        const PolygonWithHoles comp_edges = simplified(comp, kSimplify_m);
        const bool solved = params.search.mode == SearchMode::kPaper
                                ? solve_paper_component(comp, comp_edges, ci, ctx,
                                                        budget.component_deadline(), result, covered, why)
                                : solve_best_first_component(comp, comp_edges, comp_area, ci, ctx, budget,
                                                             result, covered, why);
        if (solved) continue;
      }
      reasons.push_back("component " + std::to_string(ci) + why);
    }
    result.coverage = total_area > 0 ? std::min(1.0, covered / total_area) : 0.0;
    finish_status(reasons, result);
  }
  result.search_ms = ms_since(t0);
  return result;
}

}  // namespace

LayoutResult find_layout(const std::vector<PolygonWithHoles>& components,
                         const std::vector<BoxFormat>& formats, const LayoutParams& params,
                         const SeamEvidence* seams, const LayerSurroundings* surroundings,
                         SearchMemory* memory) {
  if (std::string bad = box_formats_problem(formats); !bad.empty()) {
    LayoutResult result;
    result.reason = bad;
    return result;
  }
  const DistinctFormats distinct = distinct_formats(formats);
  LayoutResult result =
      find_distinct_layout(components, distinct.formats, params, seams, surroundings, memory);
  for (LayoutBox& b : result.boxes) b.format = distinct.original[static_cast<std::size_t>(b.format)];
  return result;
}

}  // namespace palletd
