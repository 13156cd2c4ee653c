// Product layout search: bottom-left canonical filling, best-first on an admissible bound
// (covered + undecided area, less the least cost the undecided cells can still add:
// search_future.cpp), greedy incumbent dives, near-equal alternatives for the ambiguity test.
// Candidate generation in search_candidates.cpp, node state in search_state.cpp.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <queue>

#include "search/best_first_internal.hpp"

namespace palletd::layout_detail {

namespace best_first {

namespace {

constexpr std::size_t kMinNodes = 16;                         ///< node cap floor, whatever the pool
constexpr std::size_t kBytesPerWord = 8;                      ///< one occupancy word (std::uint64_t)
constexpr std::size_t kReservedNodes = std::size_t{1} << 16;  ///< nodes reserved up front
constexpr double kSameLayoutTolOfSide = 0.25;  ///< same-box centre tolerance / sqrt(smallest box area)
constexpr double kBoundQuantaPerM2 = 1e8;      ///< queue bounds are compared in units of 1e-8 m^2
constexpr double kScoreEpsM2 = 1e-12;          ///< an incumbent better by more than this wins
constexpr std::size_t kClockCheckMask = 127;   ///< the deadline is read once every 128 pops
constexpr std::size_t kDiveMask = 63;          ///< until a best is found, every 64th pop dives

std::int64_t quantized(double bound_m2) {
  return static_cast<std::int64_t>(std::llround(bound_m2 * kBoundQuantaPerM2));
}

}  // namespace

ComponentSolution BestFirstSearch::run() {
  ComponentSolution sol;
  if (!build(&sol.reason)) return sol;
  start_search();
  dive(0, -1);
  // One dive per format too: a layer of one format among absent ones is tiled by it, and its
  // score as the incumbent prunes the mixes that cannot come near it.
  if (formats_.size() > 1) {
    for (int f = 0; f < static_cast<int>(formats_.size()); ++f) dive(0, f);
  }
  // And one per shape (a format and its turn): a brick layer stands all one way, rows offset by
  // half a carton, where a dive free to turn each carton gets stuck at the far edge.
  if (shapes_.size() > 1) {
    for (int s = 0; s < static_cast<int>(shapes_.size()); ++s)
      dive(0, shapes_[static_cast<std::size_t>(s)].format, s);
  }
  search_best_first(&sol);
  fill_solution(&sol);
  return sol;
}

// Node cap, margins, and the root node (nothing decided) on the queue.
void BestFirstSearch::start_search() {
  max_nodes_ =
      std::max<std::size_t>(kMinNodes, std::min(params_.search.max_nodes, kMaxPoolBytes / (words_ * kBytesPerWord)));
  // Fresh containers reserve room for a typical search; kept ones (SearchMemory) grow only when
  // this search needs more than they hold.
  if (nodes_.capacity() == 0) nodes_.reserve(std::min<std::size_t>(max_nodes_, kReservedNodes));
  if (pool_.capacity() == 0) pool_.reserve(std::min<std::size_t>(max_nodes_, kReservedNodes) * words_);
  tie_margin_m2_ = tie_margin_m2(params_, formats_);
  same_tol_m_ = kSameLayoutTolOfSide * std::sqrt(min_box_area_);
  double future = 0.0;
  for (double f : future_cost_) future += f;
  nodes_.push_back({0, 0, 0, future, -1, -2, 0, false});
  pool_.resize(words_, 0);
  advance(nodes_[0], occ(0));
  queue_.push({quantized(bound_of(nodes_[0])), nodes_[0].cursor, 0});
}

// Pops nodes best bound first until the queue runs dry, the bound falls below the floor, the
// alternatives are full or the budget runs out (exhausted_).
void BestFirstSearch::search_best_first(ComponentSolution* sol) {
  while (!queue_.empty()) {
    // The expansion count is the budget; the clock only caps a loaded or slow machine.
    clock_ran_out_ = pops_ < budget_.expansions && (pops_ & kClockCheckMask) == kClockCheckMask &&
                     budget_.deadline.passed();
    if (pops_ >= budget_.expansions || clock_ran_out_) {
      exhausted_ = true;
      break;
    }
    ++pops_;
    const QueueItem item = queue_.top();
    queue_.pop();
    const int k = static_cast<int>(item.node);
    const Node cur = nodes_[item.node];
    const double bound = bound_of(cur);
    if (bound < floor_score()) break;  // nothing left within the margin
    if (cur.complete) {
      if (take_complete(k, sol)) break;
      continue;
    }
    if (best_ < 0 && (pops_ & kDiveMask) == 0) dive(k, -1);
    expand(item, cur.cursor);
    if (exhausted_) break;
  }
}

// A complete layout off the queue: the best (the first one, unless the incumbent is better) or a
// near-equal alternative. Returns true when the alternatives are full and the search ends.
bool BestFirstSearch::take_complete(int k, ComponentSolution* sol) {
  if (best_ < 0) {
    if (incumbent_ >= 0 && score_of(incumbent_) > score_of(k) + kScoreEpsM2) {
      best_ = incumbent_;  // the dive found better; this one may be an alternative
      best_boxes_ = boxes_of(incumbent_);
    } else {
      best_ = k;
      best_boxes_ = boxes_of(k);
      return false;
    }
  }
  // A materially different layout within the margin: keep it (up to kMaxAlternatives) so
  // that the caller can rank the near-equal outline hypotheses by other evidence.
  std::vector<FrameBox> boxes = boxes_of(k);
  if (same_layout(boxes, best_boxes_, same_tol_m_)) return false;
  bool dup = false;
  for (const auto& a : sol->alternatives) dup = dup || same_layout(boxes, a, same_tol_m_);
  if (dup) return false;
  if (runner_ < 0) runner_ = k;
  sol->alternatives.push_back(std::move(boxes));
  sol->alternative_scores.push_back(score_of(k));
  return sol->alternatives.size() >= kMaxAlternatives;
}

// Children of the popped node at its cursor cell: the cell left uncovered, then every placement
// that fits. Sets exhausted_ when the node cap is reached.
void BestFirstSearch::expand(const QueueItem& item, int cell) {
  const int k = static_cast<int>(item.node);
  const auto& list = placements_[static_cast<std::size_t>(cell)];
  // Which placements fit, read before any child is made (a child may move the pool).
  FreeRuns runs(occ(item.node), cell, nx_);
  fitting_.clear();
  for (const Placement& p : list) fitting_.push_back(runs.fits(p) ? 1 : 0);
  for (int pi = -1; pi < static_cast<int>(list.size()); ++pi) {
    if (nodes_.size() >= max_nodes_) {
      exhausted_ = true;
      break;
    }
    if (pi >= 0 && fitting_[static_cast<std::size_t>(pi)] == 0) continue;
    admit_child(make_child(k, pi));
  }
}

// Queues the newest node `idx`, or drops it when it cannot come within the margin of the best, it
// covers less than the outline minimum, or better pasts with its frontier dominate it.
void BestFirstSearch::admit_child(std::size_t idx) {
  const Node& child = nodes_[idx];
  const double child_bound = bound_of(child);
  if (child_bound < floor_score() || total_area_ - child.lost < min_outline_) {
    drop_last_node();
    return;
  }
  if (!child.complete && dominated(child, idx)) {
    drop_last_node();
    return;
  }
  const int ci = static_cast<int>(idx);
  if (score_of(ci) > score_of(best_seen_) ||
      (child.complete && !nodes_[static_cast<std::size_t>(best_seen_)].complete &&
       score_of(ci) >= score_of(best_seen_))) {
    best_seen_ = ci;
  }
  queue_.push({quantized(child_bound), child.cursor, static_cast<std::uint32_t>(idx)});
}

// Dominance: of the nodes sharing a frontier, only the few best pasts can lead to the best layout
// or to one of the kept near-equal alternatives. A child that is not dominated counts as one of
// them.
bool BestFirstSearch::dominated(const Node& child, std::size_t idx) {
  auto& d = frontier_[frontier_key(child, occ(idx))];
  const double past = child.covered - child.penalty;
  if (d.count > 0 && (past < d.best - tie_margin_m2_ || d.count > kMaxAlternatives)) return true;
  d.best = d.count == 0 ? past : std::max(d.best, past);
  ++d.count;
  return false;
}

void BestFirstSearch::drop_last_node() {
  nodes_.pop_back();
  pool_.resize(pool_.size() - words_);
}

// Child of node k placing placement pi of its cursor cell (-1 = leave the cell uncovered).
std::size_t BestFirstSearch::make_child(int k, int pi) {
  const Node cur = nodes_[static_cast<std::size_t>(k)];
  const int c = cur.cursor;
  Node child = cur;
  child.parent = k;
  child.placement = pi;
  const std::size_t idx = nodes_.size();
  pool_.resize(pool_.size() + words_);
  std::copy(occ(static_cast<std::size_t>(k)), occ(static_cast<std::size_t>(k)) + words_, occ(idx));
  std::uint64_t* o = occ(idx);
  if (pi < 0) {
    o[c >> 6] |= std::uint64_t{1} << (c & 63);
    child.lost += cell_area_[static_cast<std::size_t>(c)];
    child.future -= future_cost_[static_cast<std::size_t>(c)];
  } else {
    const Placement& p = placements_[static_cast<std::size_t>(c)][static_cast<std::size_t>(pi)];
    const int i = c % nx_, j = c / nx_;
    for (int row = j; row < p.j1; ++row) set_range(o, row * nx_ + i, p.i1 - i);
    child.covered += p.area;
    child.penalty += p.penalty;
    child.future -= p.future;
  }
  ++child.cursor;
  advance(child, o);
  nodes_.push_back(child);
  return idx;
}

// Incumbent: a complete layout from greedy dives (most promising fitting box first, of any format,
// of one format only or of one shape only). It only tightens the pruning (nothing below incumbent - margin
// can be within the margin of the best), so the bound stays admissible; when the budget runs out, it is a
// complete answer.
void BestFirstSearch::dive(int k, int format, int shape) {
  while (!nodes_[static_cast<std::size_t>(k)].complete) {
    if (nodes_.size() >= max_nodes_) return;
    const int c = nodes_[static_cast<std::size_t>(k)].cursor;
    const auto& list = placements_[static_cast<std::size_t>(c)];
    FreeRuns runs(occ(static_cast<std::size_t>(k)), c, nx_);
    int pick = -1;
    for (int pi = 0; pi < static_cast<int>(list.size()); ++pi) {
      const Placement& p = list[static_cast<std::size_t>(pi)];
      if (format >= 0 && shapes_[static_cast<std::size_t>(p.shape)].format != format) continue;
      if (shape >= 0 && p.shape != shape) continue;
      if (runs.fits(p)) {
        pick = pi;
        break;
      }
    }
    k = static_cast<int>(make_child(k, pick));
  }
  if (nodes_[static_cast<std::size_t>(k)].covered < min_outline_) return;
  if (incumbent_ < 0 || score_of(k) > score_of(incumbent_)) incumbent_ = k;
}

double BestFirstSearch::score_of(int k) const {
  const Node& n = nodes_[static_cast<std::size_t>(k)];
  return n.covered - n.penalty;
}

// Bounds below this cannot come within the margin of the best (or the incumbent).
double BestFirstSearch::floor_score() const {
  double f = -1e300;
  if (best_ >= 0) f = score_of(best_);
  if (incumbent_ >= 0) f = std::max(f, score_of(incumbent_));
  return f - tie_margin_m2_;
}

// The chosen layout (the best, else the highest-scoring node seen), the runner-up and the counts.
void BestFirstSearch::fill_solution(ComponentSolution* sol) {
  // The queue ran dry below the incumbent: the incumbent is the best (within the margin).
  if (best_ < 0 && !exhausted_ && incumbent_ >= 0) {
    best_ = incumbent_;
    best_boxes_ = boxes_of(incumbent_);
  }
  if (best_ < 0 && incumbent_ >= 0 && score_of(incumbent_) >= score_of(best_seen_)) best_seen_ = incumbent_;
  sol->visited = nodes_.size();
  sol->expansions = pops_;
  sol->budget_exhausted = exhausted_;
  sol->clock_ran_out = clock_ran_out_;
  const int chosen = best_ >= 0 ? best_ : best_seen_;
  sol->boxes = best_ >= 0 ? best_boxes_ : boxes_of(chosen);
  sol->score = score_of(chosen);
  sol->outline_score = nodes_[static_cast<std::size_t>(chosen)].covered;
  sol->found = !sol->boxes.empty();
  if (!sol->found) sol->reason = "no box of the recipe fits the outline";
  if (runner_ >= 0) {
    sol->has_runner_up = true;
    sol->runner_up = boxes_of(runner_);
    sol->runner_up_score = score_of(runner_);
  }
}

}  // namespace best_first

ComponentSolution search_best_first(const PolygonWithHoles& frame_polygon,
                                    const PolygonWithHoles& frame_edges,
                                    const std::vector<BoxFormat>& formats, const LayoutParams& params,
                                    const SeamTable* seams, const SearchBudget& budget,
                                    double min_outline_score, const SeedEdgeFilter& seed_ok,
                                    SearchMemory* memory) {
  SearchMemory own;
  SearchMemory::Storage& storage = (memory != nullptr ? *memory : own).storage();
  ComponentSolution sol = best_first::BestFirstSearch(frame_polygon, frame_edges, formats, params, seams,
                                                      budget, min_outline_score, seed_ok, storage)
                              .run();
  storage.settle();
  return sol;
}

}  // namespace palletd::layout_detail

namespace palletd {

SearchMemory::SearchMemory() = default;

SearchMemory::SearchMemory(std::size_t kept_pool_bytes, std::size_t kept_nodes)
    : storage_(std::make_unique<Storage>()) {
  storage_->kept_pool_words =
      std::max<std::size_t>(1, kept_pool_bytes / layout_detail::best_first::kBytesPerWord);
  storage_->kept_nodes = std::max<std::size_t>(1, kept_nodes);
  storage_->hold();
}

void SearchMemory::Storage::hold() {
  // Every page written: the memory is resident from now on.
  layout_detail::best_first::hold_exactly(pool, kept_pool_words);
  layout_detail::best_first::hold_exactly(nodes, kept_nodes);
  queue.hold(kept_nodes);
  frontier.hold(kept_nodes);
  kept_slots = frontier.capacity();
}

void SearchMemory::Storage::settle() {
  if (kept_pool_words == 0) return;
  if (pool.capacity() > kept_pool_words || nodes.capacity() > kept_nodes || queue.capacity() > kept_nodes ||
      frontier.capacity() > kept_slots) {
    hold();
  }
}
SearchMemory::~SearchMemory() = default;
SearchMemory::SearchMemory(SearchMemory&&) noexcept = default;
SearchMemory& SearchMemory::operator=(SearchMemory&&) noexcept = default;

SearchMemory::Storage& SearchMemory::storage() {
  if (!storage_) storage_ = std::make_unique<Storage>();
  return *storage_;
}

}  // namespace palletd
