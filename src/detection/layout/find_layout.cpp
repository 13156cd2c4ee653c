// find_layout(): input checks, components, layout frames, search dispatch, per-box scores.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>

#include "layout_internal.hpp"
#include "layout_scoring.hpp"
#include "seam_likelihood.hpp"

namespace palletd {

using namespace layout_detail;

namespace {

constexpr double kSimplify_m = 0.004;  ///< outline simplification for corners and lines [m]

std::string check_formats(const std::vector<BoxFormat>& formats) {
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

Eigen::Vector2d centroid_of(const Ring2d& ring) {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const auto& p : ring) c += p;
  return ring.empty() ? c : Eigen::Vector2d(c / static_cast<double>(ring.size()));
}

/// Two hypotheses whose seam agreement differs by less than this share of the shortest box
/// side [m of seam line] are not separated by the seams (-> ambiguous).
constexpr double kSeamSeparation = 0.3;
/// Seams predicted and absent count together for at most this share of the decisive evidence:
/// alone they never decide (a gap can be pressed shut), a seam that shows must.
constexpr double kAbsentShare = 0.9;

/// Median of the seam values of 4 cm pieces along a line [0, 1]; `value(piece)` reads a piece.
template <typename ValueFn>
double median_along(double lo, double hi, ValueFn&& value) {
  const double seg = 0.04;
  const int n = std::max(1, static_cast<int>((hi - lo) / seg + 0.5));
  const double step = (hi - lo) / n;
  std::vector<double> v;
  for (int k = 0; k < n; ++k) {
    const double x = value(lo + k * step, lo + (k + 1) * step);
    if (x >= 0.0) v.push_back(x);  // negative: no neighbour there, not part of the seam line
  }
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// How well a frame layout agrees with the seam lines [m]: the length of box edges shared with
/// a neighbour, each weighted by the median seam support along the whole edge, minus the
/// length of the strongest seam line across each box interior, weighted by the median along
/// it. Medians over whole edges and widths make short edges inside boxes (tape, labels) and
/// scattered dropouts weigh nothing against a seam along a full box edge.
double seam_agreement(const std::vector<FrameBox>& boxes, const SeamTable& table,
                      const PolygonWithHoles& frame_polygon, const LayoutParams& params) {
  const double m = params.seam_margin_m;
  const double cell = table.cell();
  auto layer_area = [&](const Rect& q) { return clipped_area(frame_polygon, q.x0, q.y0, q.x1, q.y1); };
  double agree = 0.0;
  for (const auto& fb : boxes) {
    const Rect& r = fb.rect;
    for_each_box_side(r, m, [&](const BoxSide& side) {
      double shared = 0.0;
      const double med = median_along(side.lo, side.hi, [&](double s0, double s1) {
        const Rect beyond = side.beyond(s0, s1);
        if (layer_area(beyond) < 0.5 * beyond.area()) return -1.0;
        shared += s1 - s0;
        return std::min(1.0, 2.0 * table.support(side.line(s0, s1, cell)));
      });
      agree += shared * med;
    });
    double crossing = 0.0;
    const double lx = r.x1 - r.x0 - 2 * m, ly = r.y1 - r.y0 - 2 * m;
    if (lx <= 0 || ly <= 0) continue;
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
    agree -= crossing;
  }
  return agree;
}

struct Candidate {
  LayoutFrame frame;
  std::vector<FrameBox> boxes;
  double score = 0.0;
  std::size_t orientation = 0;
};

}  // namespace

LayoutResult find_layout(const std::vector<PolygonWithHoles>& components,
                         const std::vector<BoxFormat>& formats, const LayoutParams& params,
                         const SeamEvidence* seams, const LayerSurroundings* surroundings) {
  const auto t0 = std::chrono::steady_clock::now();
  LayoutResult result;
  auto finish = [&]() {
    result.search_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return result;
  };
  if (std::string bad = check_formats(formats); !bad.empty()) {
    result.reason = bad;
    return finish();
  }
  if (components.empty()) {
    result.reason = "the layer has no outline";
    return finish();
  }
  double min_box_area = 1e9, min_short = 1e9;
  for (const auto& f : formats) {
    min_box_area = std::min(min_box_area, f.long_m * f.short_m);
    min_short = std::min(min_short, f.short_m);
  }
  const double min_edge = std::max(0.02, 0.25 * min_short);
  const double tie_margin = tie_margin_m2(params, formats);
  // Absent seams together never decide (kAbsentShare of the decisive evidence).
  const double absent_cap = kAbsentShare * SeamLikelihood::decisive_nats(min_short);
  const auto budget = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double, std::milli>(std::max(0.0, params.time_budget_ms)));
  const auto end = t0 + budget;
  // Expansions left for the product searches, shared in a fixed way (deterministic).
  std::size_t expansions_left = params.search_expansions;

  double total_area = 0.0, covered = 0.0;
  std::vector<std::string> reasons;
  for (std::size_t ci = 0; ci < components.size(); ++ci) {
    const PolygonWithHoles& comp = components[ci];
    const PolygonWithHoles comp_edges = simplified(comp, kSimplify_m);
    const double comp_area = area(comp);
    total_area += comp_area;
    if (comp.outer.size() < 3 || !(comp_area > 0.0)) {
      reasons.push_back("component " + std::to_string(ci) + " has no area");
      continue;
    }
    // A component smaller than a box may be a box the outline cuts where the depth ends.
    const bool may_complete = surroundings != nullptr && !surroundings->empty() && params.unseen_min_fraction > 0.0 &&
                              params.search == SearchMode::product;
    // The product search counts the outline grown by its tolerance towards a_min: at most the
    // tolerance times the rings' length more (a lone box at a coarse pitch measures smaller).
    double grown_area = comp_area;
    if (params.search == SearchMode::product && params.outline_tolerance_m > 0.0) {
      grown_area += params.outline_tolerance_m * rings_length_m(comp) +
                    4.0 * params.outline_tolerance_m * params.outline_tolerance_m;
    }
    if (grown_area < (may_complete ? params.unseen_min_fraction : params.a_min_fraction) * min_box_area) {
      reasons.push_back("component " + std::to_string(ci) + " is smaller than every box format");
      continue;
    }
    // Share what is left of the budget among the components still to solve.
    const auto now = std::chrono::steady_clock::now();
    const auto left = end > now ? end - now : std::chrono::steady_clock::duration::zero();
    const Deadline deadline{now + left / static_cast<long>(components.size() - ci)};
    std::size_t comp_expansions = expansions_left / (components.size() - ci);

    if (params.search == SearchMode::paper) {
      const PaperSolution ps = search_paper(comp, comp_edges, formats, params, deadline);
      result.hypotheses_visited += ps.visited;
      result.budget_exhausted = result.budget_exhausted || ps.cap_hit;
      if (!ps.found) {
        reasons.push_back("component " + std::to_string(ci) +
                          (orthogonal_corners(comp_edges, params.corner_angle_tol_deg, min_edge).empty()
                               ? " has no orthogonal corner (round or damaged outline)"
                               : ": no box of the recipe fits its outline"));
        continue;
      }
      result.score += ps.score;
      for (const auto& b : ps.boxes) {
        result.boxes.push_back(b);
        result.box_component.push_back(static_cast<int>(ci));
        result.box_partly_unseen.push_back(false);
        const BoxSupport s = box_support(b, comp, nullptr, params);
        result.box_scores.push_back(s.score);
        covered += s.inside_area_m2;
      }
      continue;
    }

    const std::vector<double> thetas = layout_orientations(comp_edges, params.corner_angle_tol_deg, min_edge);
    if (thetas.empty()) {
      reasons.push_back("component " + std::to_string(ci) + " has no orthogonal corner (round or damaged outline)");
      continue;
    }
    std::vector<Candidate> cands;
    std::vector<SeamTable> tables;
    std::vector<PolygonWithHoles> frame_polys;
    std::vector<LayoutFrame> frames;
    std::string why;
    const std::size_t n_orient = std::min<std::size_t>(thetas.size(), 3);
    for (std::size_t oi = 0; oi < n_orient; ++oi) {
      const auto now2 = std::chrono::steady_clock::now();
      const auto left2 = deadline.end > now2 ? deadline.end - now2 : std::chrono::steady_clock::duration::zero();
      // The best supported orientation gets most of the component's share.
      const Deadline d2{now2 + (oi + 1 == n_orient ? left2 : left2 * 3 / 4)};
      std::size_t orient_expansions = oi + 1 == n_orient ? comp_expansions : comp_expansions * 3 / 4;
      auto spend = [&](std::size_t used) {
        result.search_expansions += used;
        used = std::min(used, orient_expansions);
        orient_expansions -= used;
        comp_expansions -= std::min(used, comp_expansions);
        expansions_left -= std::min(used, expansions_left);
      };
      LayoutFrame frame;
      frame.theta_rad = thetas[oi];
      frame.pivot = centroid_of(comp.outer);
      const PolygonWithHoles fp = frame.to_frame(comp);
      const PolygonWithHoles fe = frame.to_frame(comp_edges);
      // The outline alone decides coverage: seams never enter the search score (a noisy seam
      // raster must not veto a layout the outline supports). They rank the near-equal
      // hypotheses below.
      const ComponentSolution cs = search_product(fp, fe, formats, params, nullptr, SearchBudget{orient_expansions, d2});
      spend(cs.expansions);
      const std::size_t slot = frame_polys.size();
      frame_polys.push_back(fp);
      frames.push_back(frame);
      result.hypotheses_visited += cs.visited;
      result.budget_exhausted = result.budget_exhausted || cs.budget_exhausted;
      if (!cs.found) {
        why = cs.reason;
        continue;
      }
      cands.push_back({frame, cs.boxes, cs.score, slot});
      for (std::size_t a = 0; a < cs.alternatives.size(); ++a) {
        cands.push_back({frame, cs.alternatives[a], cs.alternative_scores[a], slot});
      }
      // Too many near-equal tilings to list: let a seam-penalised search choose among the
      // layouts whose outline score is within the margin of the best (never fewer boxes).
      if (cs.alternatives.size() >= kMaxAlternatives && !cs.budget_exhausted && seams != nullptr &&
          !seams->empty() && seams->strength > 0.0) {
        const SeamTable table(*seams, frame, bounds_of(fp));
        if (!table.empty()) {
          const auto now3 = std::chrono::steady_clock::now();
          const auto left3 = d2.end > now3 ? d2.end - now3 : std::chrono::steady_clock::duration::zero();
          const ComponentSolution ss =
              search_product(fp, fe, formats, params, &table, SearchBudget{orient_expansions, Deadline{now3 + left3}},
                             cs.score - tie_margin);
          spend(ss.expansions);
          result.hypotheses_visited += ss.visited;
          result.budget_exhausted = result.budget_exhausted || ss.budget_exhausted;
          if (ss.found) cands.push_back({frame, ss.boxes, ss.outline_score, slot});
          for (const auto& alt : ss.alternatives) {
            double covered_m2 = 0.0;  // its outline score
            for (const auto& b : alt) covered_m2 += clipped_area(fp, b.rect.x0, b.rect.y0, b.rect.x1, b.rect.y1);
            cands.push_back({frame, alt, covered_m2, slot});
          }
        }
      }
    }
    // Boxes completed across edges where the depth ends: all of them, or the last `completed`.
    bool all_completed = false, completion_tied = false;
    std::size_t completed = 0;
    if (cands.empty() && may_complete && !frames.empty()) {
      // Nothing the outline alone supports: perhaps boxes it cuts where the depth ends.
      const UnseenCompletion uc = complete_unseen({}, frame_polys[0], frames[0].to_frame(comp_edges), frames[0],
                                                  formats, *surroundings, params);
      if (uc.added > 0) {
        cands.push_back({frames[0], uc.boxes, 0.0, 0});
        all_completed = true;
        completion_tied = uc.tied || uc.open;
        result.completed_unseen += uc.added;
      }
    }
    if (cands.empty()) {
      reasons.push_back("component " + std::to_string(ci) + ": " + (why.empty() ? "no layout found" : why));
      continue;
    }
    std::stable_sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
    // Near-equal outline hypotheses: materially different layouts within the ambiguity margin.
    const double same_tol = 0.25 * std::sqrt(min_box_area);
    const double margin = tie_margin;
    std::vector<std::size_t> near{0};
    for (std::size_t k = 1; k < cands.size(); ++k) {
      const Candidate& c = cands[k];
      if (cands.front().score - c.score >= margin) break;
      bool dup = false;
      for (std::size_t n : near) {
        const Candidate& o = cands[n];
        dup = dup || (std::abs(c.frame.theta_rad - o.frame.theta_rad) < 1e-9 && same_layout(c.boxes, o.boxes, same_tol));
      }
      if (!dup) near.push_back(k);
    }
    const bool have_seams = seams != nullptr && !seams->empty() && seams->strength > 0.0;
    tables.resize(frame_polys.size());
    auto table_of = [&](std::size_t slot) -> const SeamTable* {
      if (!have_seams) return nullptr;
      if (tables[slot].empty()) tables[slot] = SeamTable(*seams, frames[slot], bounds_of(frame_polys[slot]));
      return tables[slot].empty() ? nullptr : &tables[slot];
    };
    // Rank the near-equal hypotheses: by the seam likelihood (seam_likelihood.hpp) when they share
    // a layout frame and the frame's seams stand out of its box tops; otherwise by the older
    // seam agreement (line integrals along whole edges).
    std::vector<std::size_t> order = near;
    bool ambiguous = near.size() > 1;
    bool decided = false;
    bool seams_invisible = false;  // measured, and not standing out of the box tops
    if (near.size() > 1 && have_seams) {
      // Seam likelihood among the near-equal layouts of one layout frame (the usual case): the
      // pieces where two layouts disagree decide, against noise levels taken from the frame.
      const std::size_t slot = cands[near.front()].orientation;
      bool one_frame = true;
      for (std::size_t n : near) one_frame = one_frame && cands[n].orientation == slot;
      if (one_frame) {
        const double tol = params.line_merge_tol_m > 0 ? params.line_merge_tol_m : std::clamp(0.06 * min_short, 0.006, 0.02);
        SeamLikelihood lik(*seams, frames[slot], frame_polys[slot], tol, params.seam_margin_m, absent_cap);
        std::vector<const std::vector<FrameBox>*> layouts;
        for (std::size_t n : near) layouts.push_back(&cands[n].boxes);
        if (lik.calibrate(layouts)) {
          // Evidence of each against the outline's best, then the winner against every other.
          std::vector<double> ev(near.size(), 0.0);
          for (std::size_t i = 1; i < near.size(); ++i) ev[i] = lik.compare(cands[near[i]].boxes, cands[near[0]].boxes);
          const auto w = static_cast<std::size_t>(std::max_element(ev.begin(), ev.end()) - ev.begin());
          double margin_nats = 1e300;
          for (std::size_t i = 0; i < near.size(); ++i) {
            if (i != w) margin_nats = std::min(margin_nats, lik.compare(cands[near[w]].boxes, cands[near[i]].boxes));
          }
          order.clear();
          order.push_back(near[w]);
          for (std::size_t i = 0; i < near.size(); ++i)
            if (i != w) order.push_back(near[i]);
          ambiguous = margin_nats < SeamLikelihood::decisive_nats(min_short);
          decided = true;
        } else if (lik.measured()) {
          // The seams were measured and do not stand out of the box tops: nothing inside the
          // layer tells these layouts apart. The older agreement below still picks the best
          // guess, but cannot settle it.
          seams_invisible = true;
        }
      }
    }
    if (near.size() > 1 && have_seams && !decided) {
      std::vector<double> agree(cands.size(), 0.0);
      for (std::size_t n : near) {
        const SeamTable* t = table_of(cands[n].orientation);
        agree[n] = t == nullptr ? 0.0 : seam_agreement(cands[n].boxes, *t, frame_polys[cands[n].orientation], params);
      }
      std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return agree[a] > agree[b]; });
      ambiguous = seams_invisible || agree[order[0]] - agree[order[1]] < kSeamSeparation * min_short;
    }
    Candidate best = cands[order.front()];
    // Outline-equal footprint moves (a box or two turned into other boxes of the recipe on the
    // same rectangle) are too many to list as alternatives in mixed-format layers: the seams
    // decide each one; one they cannot decide leaves the layout ambiguous.
    {
      const double tol = params.line_merge_tol_m > 0 ? params.line_merge_tol_m : std::clamp(0.06 * min_short, 0.006, 0.02);
      const std::vector<FootprintMove> moves = footprint_moves(best.boxes, formats, tol);
      if (!moves.empty()) {
        std::unique_ptr<SeamLikelihood> lik;
        if (have_seams) {
          lik = std::make_unique<SeamLikelihood>(*seams, best.frame, frame_polys[best.orientation], tol,
                                                 params.seam_margin_m, absent_cap);
          const std::vector<FrameBox> overlay = moves_overlay(best.boxes, moves);
          std::vector<const std::vector<FrameBox>*> calibration{&best.boxes, &overlay};
          for (std::size_t n : near) {
            if (cands[n].orientation == best.orientation) calibration.push_back(&cands[n].boxes);
          }
          lik->calibrate(calibration);
        }
        const RetileResult rr =
            retile_by_seams(&best.boxes, formats, lik.get(), tol, SeamLikelihood::decisive_nats(min_short));
        ambiguous = ambiguous || rr.tied;
      }
    }
    ambiguous = ambiguous || completion_tied;
    if (may_complete && !all_completed) {
      // A search again when part of the outline is unseen may take a tenth of the call's budget
      // beyond what is left of the component's share.
      const SearchBudget research{std::max(comp_expansions, params.search_expansions / 10), deadline};
      const UnseenCompletion uc = complete_unseen(best.boxes, frame_polys[best.orientation],
                                                  best.frame.to_frame(comp_edges), best.frame, formats, *surroundings,
                                                  params, &research);
      result.search_expansions += uc.expansions;
      expansions_left -= std::min(uc.expansions, expansions_left);
      best.boxes = uc.boxes;
      completed = uc.added;
      ambiguous = ambiguous || uc.tied || uc.open;
      result.completed_unseen += uc.added;
    }
    // A piece of the layer that no box covers and that is more than a gap: the outline is not
    // explained, so the layout is in doubt there (a box of another format, or the wrong tiling).
    if (params.uncovered_flag_fraction > 0.0 &&
        largest_uncovered_m2(frame_polys[best.orientation], best.boxes, 0.02) >=
            params.uncovered_flag_fraction * min_box_area) {
      ambiguous = true;
    }
    result.score += best.score;
    result.ambiguous = result.ambiguous || ambiguous;
    if (order.size() > 1) {
      const Candidate& c = cands[order[1]];
      const double gap = std::abs(best.score - c.score);
      if (result.runner_up_gap < 0 || gap < result.runner_up_gap) {
        result.runner_up_gap = gap;
        result.runner_up.clear();
        for (const auto& b : c.boxes) result.runner_up.push_back(c.frame.to_layer(b, formats));
      }
    }
    double comp_covered = 0;
    std::vector<BoxSupport> support;
    const SeamTable* best_table = table_of(best.orientation);
    for (const auto& fb : best.boxes) {
      support.push_back(box_support(best.frame.to_layer(fb, formats), best.frame, frame_polys[best.orientation],
                                    best_table, params));
      comp_covered += support.back().inside_area_m2;
    }
    if (comp_covered < params.min_coverage * comp_area) {
      reasons.push_back("component " + std::to_string(ci) + ": boxes of the recipe cover only " +
                        std::to_string(static_cast<int>(100.0 * comp_covered / comp_area)) +
                        "% of it (its boxes match no recipe format)");
      continue;
    }
    covered += comp_covered;
    for (std::size_t k = 0; k < best.boxes.size(); ++k) {
      result.boxes.push_back(best.frame.to_layer(best.boxes[k], formats));
      result.box_component.push_back(static_cast<int>(ci));
      result.box_scores.push_back(support[k].score);
      result.box_partly_unseen.push_back(all_completed || k + completed >= best.boxes.size());
    }
  }
  result.coverage = total_area > 0 ? std::min(1.0, covered / total_area) : 0.0;
  if (result.boxes.empty()) {
    result.status = DetectionStatus::no_layout;
    std::string r;
    for (const auto& s : reasons) r += (r.empty() ? "" : "; ") + s;
    result.reason = r.empty() ? "no layout found" : r;
  } else {
    result.status = DetectionStatus::ok;
    std::string r;
    for (const auto& s : reasons) r += (r.empty() ? "" : "; ") + s;
    result.reason = r;
  }
  return finish();
}

}  // namespace palletd
