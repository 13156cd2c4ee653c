// Product layout search: bottom-left canonical filling, best-first on an admissible bound
// (covered + undecided area), greedy incumbent dives, near-equal alternatives for the ambiguity
// test. Candidate generation in search_candidates.cpp, node state in search_state.cpp.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <queue>
#include <unordered_map>

#include "search/search_product_internal.hpp"

namespace palletd::layout_detail {

namespace product {

ComponentSolution ProductSearch::run() {
  ComponentSolution sol;
  if (!build(&sol.reason)) return sol;
  const std::size_t max_nodes =
      std::max<std::size_t>(16, std::min(params_.max_nodes, kMaxPoolBytes / (words_ * 8)));
  nodes_.reserve(std::min<std::size_t>(max_nodes, 1 << 16));
  pool_.reserve(std::min<std::size_t>(max_nodes, 1 << 16) * words_);
  const double margin = tie_margin_m2(params_, formats_);
  const double same_tol = 0.25 * std::sqrt(min_box_area_);
  auto quant = [](double b) { return static_cast<std::int64_t>(std::llround(b * 1e8)); };

  struct Dominance {
    double best = 0.0;
    std::size_t count = 0;
  };
  std::unordered_map<std::uint64_t, Dominance> frontier;
  std::priority_queue<QueueItem> queue;
  nodes_.push_back({0, 0, 0, -1, -2, -1, 0, false});
  pool_.resize(words_, 0);
  advance(nodes_[0], occ(0));
  queue.push({quant(total_area_ - nodes_[0].lost), nodes_[0].cursor, 0});

  int best = -1, runner = -1;
  int best_seen = 0;  // highest score over all generated nodes (the paper's H_max)
  auto score_of = [&](int k) {
    const Node& n = nodes_[static_cast<std::size_t>(k)];
    return n.covered - n.penalty;
  };
  // Child of node k placing placement pi of its cursor cell (-1 = leave the cell uncovered).
  auto make_child = [&](int k, int pi) -> std::size_t {
    const Node cur = nodes_[static_cast<std::size_t>(k)];
    const int c = cur.cursor;
    Node child = cur;
    child.parent = k;
    child.placement = pi;
    child.cell = c;
    const std::size_t idx = nodes_.size();
    pool_.resize(pool_.size() + words_);
    std::copy(occ(static_cast<std::size_t>(k)), occ(static_cast<std::size_t>(k)) + words_, occ(idx));
    std::uint64_t* o = occ(idx);
    if (pi < 0) {
      o[c >> 6] |= std::uint64_t{1} << (c & 63);
      child.lost += cell_area_[static_cast<std::size_t>(c)];
    } else {
      const Placement& p = placements_[static_cast<std::size_t>(c)][static_cast<std::size_t>(pi)];
      const int i = c % nx_, j = c / nx_;
      for (int row = j; row < p.j1; ++row) set_range(o, row * nx_ + i, p.i1 - i);
      child.covered += p.area;
      child.penalty += p.penalty;
    }
    ++child.cursor;
    advance(child, o);
    nodes_.push_back(child);
    return idx;
  };
  // Incumbent: a complete layout from greedy dives (largest fitting box first). It only tightens
  // the pruning (nothing below incumbent - margin can be within the margin of the best), so the
  // bound stays admissible; when the budget runs out, it is a complete answer.
  int incumbent = -1;
  auto dive = [&](int k) {
    while (!nodes_[static_cast<std::size_t>(k)].complete) {
      if (nodes_.size() >= max_nodes) return;
      const int c = nodes_[static_cast<std::size_t>(k)].cursor;
      const auto& list = placements_[static_cast<std::size_t>(c)];
      int pick = -1;
      for (int pi = 0; pi < static_cast<int>(list.size()); ++pi) {
        if (fits(occ(static_cast<std::size_t>(k)), c, list[static_cast<std::size_t>(pi)])) {
          pick = pi;
          break;
        }
      }
      k = static_cast<int>(make_child(k, pick));
    }
    if (nodes_[static_cast<std::size_t>(k)].covered < min_outline_) return;
    if (incumbent < 0 || score_of(k) > score_of(incumbent)) incumbent = k;
  };
  auto floor_score = [&]() {
    double f = -1e300;
    if (best >= 0) f = score_of(best);
    if (incumbent >= 0) f = std::max(f, score_of(incumbent));
    return f - margin;
  };
  dive(0);
  std::vector<FrameBox> best_boxes;
  std::size_t pops = 0;
  bool exhausted = false;
  while (!queue.empty()) {
    // The expansion count is the budget; the clock only caps a loaded or slow machine.
    if (pops >= budget_.expansions || ((pops & 127U) == 127U && budget_.deadline.passed())) {
      exhausted = true;
      break;
    }
    ++pops;
    const QueueItem item = queue.top();
    queue.pop();
    const int k = static_cast<int>(item.node);
    const Node cur = nodes_[item.node];
    const double bound = total_area_ - cur.lost - cur.penalty;
    if (bound < floor_score()) break;  // nothing left within the margin
    if (cur.complete) {
      if (best < 0) {
        if (incumbent >= 0 && score_of(incumbent) > score_of(k) + 1e-12) {
          best = incumbent;  // the dive found better; this one may be an alternative
          best_boxes = boxes_of(incumbent);
        } else {
          best = k;
          best_boxes = boxes_of(k);
          continue;
        }
      }
      // A materially different layout within the margin: keep it (up to kMaxAlternatives) so
      // that the caller can rank the near-equal outline hypotheses by other evidence.
      std::vector<FrameBox> boxes = boxes_of(k);
      if (same_layout(boxes, best_boxes, same_tol)) continue;
      bool dup = false;
      for (const auto& a : sol.alternatives) dup = dup || same_layout(boxes, a, same_tol);
      if (dup) continue;
      if (runner < 0) runner = k;
      sol.alternatives.push_back(std::move(boxes));
      sol.alternative_scores.push_back(score_of(k));
      if (sol.alternatives.size() >= kMaxAlternatives) break;
      continue;
    }
    if (best < 0 && (pops & 63U) == 0) dive(k);
    // Expand at the cursor cell.
    const int c = cur.cursor;
    const auto& list = placements_[static_cast<std::size_t>(c)];
    for (int pi = -1; pi < static_cast<int>(list.size()); ++pi) {
      if (nodes_.size() >= max_nodes) {
        exhausted = true;
        break;
      }
      if (pi >= 0 && !fits(occ(item.node), c, list[static_cast<std::size_t>(pi)])) continue;
      const std::size_t idx = make_child(k, pi);
      const Node& child = nodes_[idx];
      const double child_bound = total_area_ - child.lost - child.penalty;
      if (child_bound < floor_score() || total_area_ - child.lost < min_outline_) {
        nodes_.pop_back();
        pool_.resize(pool_.size() - words_);
        continue;
      }
      // Dominance: of the nodes sharing a frontier, only the few best pasts can lead to the
      // best layout or to one of the kept near-equal alternatives.
      if (!child.complete) {
        auto& d = frontier[frontier_key(child, occ(idx))];
        const double past = child.covered - child.penalty;
        if (d.count > 0 && (past < d.best - margin || d.count > kMaxAlternatives)) {
          nodes_.pop_back();
          pool_.resize(pool_.size() - words_);
          continue;
        }
        d.best = d.count == 0 ? past : std::max(d.best, past);
        ++d.count;
      }
      const int ci = static_cast<int>(idx);
      if (score_of(ci) > score_of(best_seen) || (child.complete && !nodes_[static_cast<std::size_t>(best_seen)].complete &&
                                                 score_of(ci) >= score_of(best_seen))) {
        best_seen = ci;
      }
      queue.push({quant(child_bound), child.cursor, static_cast<std::uint32_t>(idx)});
    }
    if (exhausted) break;
  }
  // The queue ran dry below the incumbent: the incumbent is the best (within the margin).
  if (best < 0 && !exhausted && incumbent >= 0) {
    best = incumbent;
    best_boxes = boxes_of(incumbent);
  }
  if (best < 0 && incumbent >= 0 && score_of(incumbent) >= score_of(best_seen)) best_seen = incumbent;
  sol.visited = nodes_.size();
  sol.expansions = pops;
  sol.budget_exhausted = exhausted;
  const int chosen = best >= 0 ? best : best_seen;
  sol.boxes = best >= 0 ? best_boxes : boxes_of(chosen);
  sol.score = score_of(chosen);
  sol.outline_score = nodes_[static_cast<std::size_t>(chosen)].covered;
  sol.found = !sol.boxes.empty();
  if (!sol.found) sol.reason = "no box of the recipe fits the outline";
  if (runner >= 0) {
    sol.has_runner_up = true;
    sol.runner_up = boxes_of(runner);
    sol.runner_up_score = score_of(runner);
  }
  return sol;
}

}  // namespace product

ComponentSolution search_product(const PolygonWithHoles& frame_polygon, const PolygonWithHoles& frame_edges,
                                 const std::vector<BoxFormat>& formats, const LayoutParams& params,
                                 const SeamTable* seams, const SearchBudget& budget, double min_outline_score,
                                 const SeedEdgeFilter& seed_ok) {
  product::ProductSearch search(frame_polygon, frame_edges, formats, params, seams, budget, min_outline_score, seed_ok);
  return search.run();
}

}  // namespace palletd::layout_detail
