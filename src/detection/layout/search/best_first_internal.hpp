// Private to the best-first layout search (search_*.cpp): its cell grid, nodes and the search
// class. Pieces: search_candidates.cpp (candidate lines, cells, placements), search_state.cpp
// (occupancy bits, canonical frontier keys, forced cells), search_future.cpp (the bound's
// look-ahead), search_best_first.cpp (best-first queue).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "layout_internal.hpp"

namespace palletd::layout_detail::best_first {

constexpr std::size_t kMaxLinesPerAxis = 240;
constexpr std::size_t kMaxPoolBytes = std::size_t{96} << 20;
/// The look-ahead's rounding allowance: a node's future cost is a running difference of sums,
/// and a bound a rounding error too tight could prune a layout at the margin's edge [m^2].
constexpr double kFutureSlackM2 = 1e-9;

struct Shape {
  double dx, dy;
  int format;
  bool long_along_x;
};

struct Placement {
  int shape;
  int i1, j1;   ///< end line indices (exclusive cell range [i, i1) x [j, j1))
  double area;  ///< Area(box ∩ layer) [m^2]
  double penalty;
  double future = 0.0;  ///< the least future cost of its cells (future_cost_ summed over them) [m^2]
};

/// Candidate lines on one axis: seeds closed under adding every (signed) box side, merged within
/// tol. Sets *capped when more than kMaxLinesPerAxis lines would be needed.
std::vector<double> close_lines(std::vector<std::pair<double, double>> seeds /* (pos, weight) */,
                                const std::vector<double>& dims, double lo, double hi, double tol,
                                bool* capped);

/// Sum over the cell range [i, i1) x [j, j1) from a summed-area table ((rows + 1) x stride).
double sat_area(const std::vector<double>& sat, std::size_t stride, int i, int j, int i1, int j1);

/// Index of the line nearest to v within tol, or -1.
int find_line(const std::vector<double>& lines, double v, double tol);

/// Seed lines of one axis from the outline's axis-aligned edges, (position, edge length) pairs,
/// by the side of the edge the layer lies on.
struct AxisSeeds {
  std::vector<std::pair<double, double>> plus;   ///< layer on the + side: boxes stack towards +
  std::vector<std::pair<double, double>> minus;  ///< layer on the - side: boxes stack towards -
  [[nodiscard]] bool empty() const { return plus.empty() && minus.empty(); }
};

/// Seed lines of both axes: x from edges along y (vertical), y from edges along x (horizontal).
struct EdgeSeeds {
  AxisSeeds x, y;
};

struct Node {
  double covered, lost, penalty;
  double future;  ///< a lower bound of the cost still to come: the undecided cells' future_cost_ [m^2]
  int parent;
  int placement;  ///< index into the placements of the parent's cursor cell, -1 = skip, -2 = root
  int cursor;     ///< first possibly undecided cell
  bool complete;
};

/// Sets the bits [start, start + len) of an occupancy, len > 0: the first and the last word take
/// the bits of the range they hold, the words between are full.
inline void set_range(std::uint64_t* occ, int start, int len) {
  const int last = start + len - 1;
  const int w0 = start >> 6, w1 = last >> 6;
  const std::uint64_t head = ~std::uint64_t{0} << (start & 63);
  const std::uint64_t tail = ~std::uint64_t{0} >> (63 - (last & 63));
  if (w0 == w1) {
    occ[w0] |= head & tail;
    return;
  }
  occ[w0] |= head;
  for (int w = w0 + 1; w < w1; ++w) occ[w] = ~std::uint64_t{0};
  occ[w1] |= tail;
}

/// The first free cell (0 bit) of an occupancy from bit `from` on, or `limit` when none is below it.
inline int next_free_bit(const std::uint64_t* occ, int from, int limit) {
  int w = from >> 6;
  const int words = (limit + 63) >> 6;
  std::uint64_t free_bits = ~occ[w] & (~std::uint64_t{0} << (from & 63));
  while (free_bits == 0) {
    if (++w >= words) return limit;
    free_bits = ~occ[w];
  }
  return std::min(limit, (w << 6) + __builtin_ctzll(free_bits));
}

/// Free cells (0 bits) of an occupancy from bit `start` on, at most `limit`.
inline int free_bits_from(const std::uint64_t* occ, int start, int limit) {
  int run = 0;
  while (run < limit) {
    const int pos = start + run;
    const std::uint64_t rest = occ[pos >> 6] >> (pos & 63);
    if (rest != 0) return std::min(limit, run + __builtin_ctzll(rest));
    run += 64 - (pos & 63);
  }
  return limit;
}

/// The free cells rightwards from one cell's column in each row from the cell's row down, under
/// one occupancy (bit per cell, row-major, nx cells a row): each row is read once, when a
/// placement first reaches it, for all the placements tested at that cell.
class FreeRuns {
 public:
  FreeRuns(const std::uint64_t* occ, int cell, int nx) : occ_(occ), i_(cell % nx), j_(cell / nx), nx_(nx) {}

  /// Whether placement p at the cell covers only free cells: the least run over its rows reaches
  /// its far side.
  bool fits(const Placement& p) {
    const int need = p.i1 - i_;
    const auto rows = static_cast<std::size_t>(p.j1 - j_);
    if (rows > least_.size()) {  // beyond the table (a grid has fewer rows): row by row
      for (int row = j_; row < p.j1; ++row)
        if (free_from(row * nx_ + i_, nx_ - i_) < need) return false;
      return true;
    }
    for (; known_ < rows; ++known_) {
      if (known_ > 0 && least_[known_ - 1] < need) return false;
      const int run = free_from((j_ + static_cast<int>(known_)) * nx_ + i_, nx_ - i_);
      least_[known_] = known_ == 0 ? run : std::min(least_[known_ - 1], run);
    }
    return least_[rows - 1] >= need;
  }

 private:
  [[nodiscard]] int free_from(int start, int limit) const { return free_bits_from(occ_, start, limit); }

  const std::uint64_t* occ_;
  int i_, j_, nx_;
  /// least_[k]: the least free run over rows j_ .. j_ + k, for k < known_ (a grid has fewer rows
  /// than the table: each side's lines are capped).
  std::array<int, 2 * kMaxLinesPerAxis> least_;
  std::size_t known_ = 0;
};

struct QueueItem {
  std::int64_t bound_q;
  int cursor;
  std::uint32_t node;
  bool operator<(const QueueItem& o) const {
    if (bound_q != o.bound_q) return bound_q < o.bound_q;
    return cursor < o.cursor;  // deeper first among equal bounds
  }
};

/// Best pasts (covered - penalty [m^2]) seen for one frontier key.
struct Dominance {
  double best = 0.0;
  std::size_t count = 0;
};

/// Frontier keys and their best pasts for one search: open addressing with linear probing in a
/// power-of-two table at most half full. A slot belongs to the search whose stamp it carries, so
/// clear() is one increment and a search's entries are never allocated one by one.
class FrontierTable {
 public:
  /// The entry of `key`; a new one has count 0.
  Dominance& operator[](std::uint64_t key) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    std::size_t i = index(key);
    while (slots_[i].stamp == stamp_) {
      if (slots_[i].key == key) return slots_[i].value;
      i = (i + 1) & mask_;
    }
    slots_[i] = {key, stamp_, {}};
    ++size_;
    return slots_[i].value;
  }
  void clear();
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] std::size_t capacity() const { return slots_.size(); }
  /// Gives back its memory and takes room for `n` entries, every page written.
  void hold(std::size_t n);

 private:
  struct Slot {
    std::uint64_t key = 0;
    std::uint32_t stamp = 0;  ///< 0: never used
    Dominance value;
  };
  /// Fibonacci hashing: the key's high bits after a multiply, as many as the table has.
  [[nodiscard]] std::size_t index(std::uint64_t key) const {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> shift_);
  }
  void resize(std::size_t slots);  ///< a power of two; re-inserts this search's entries

  std::vector<Slot> slots_;
  std::size_t size_ = 0;
  std::size_t mask_ = 0;
  int shift_ = 63;
  std::uint32_t stamp_ = 1;
  void grow() { resize(std::max<std::size_t>(1024, 2 * slots_.size())); }
};

/// Gives back a vector's memory and takes room for exactly `n` elements, every page written.
template <typename T>
void hold_exactly(std::vector<T>& v, std::size_t n) {
  std::vector<T>().swap(v);
  v.resize(n);
  v.clear();
}

/// The best-first queue; clear() empties it and keeps its capacity.
class SearchQueue : public std::priority_queue<QueueItem> {
 public:
  void clear() { c.clear(); }
  [[nodiscard]] std::size_t capacity() const { return c.capacity(); }
  /// Gives back its memory and takes room for exactly `n` items, every page written.
  void hold(std::size_t n) { hold_exactly(c, n); }
};

}  // namespace palletd::layout_detail::best_first

namespace palletd {

/// The search's containers that grow with the nodes it makes; a search clears them and keeps
/// their capacity (SearchMemory).
struct SearchMemory::Storage {
  std::vector<layout_detail::best_first::Node> nodes;
  std::vector<std::uint64_t> pool;  ///< each node's occupancy bits, `words_` per node
  layout_detail::best_first::FrontierTable frontier;
  layout_detail::best_first::SearchQueue queue;

  /// With a budget: the pool words and nodes kept between searches (0 = keep all).
  std::size_t kept_pool_words = 0;
  std::size_t kept_nodes = 0;
  std::size_t kept_slots = 0;  ///< the frontier table's slots at that budget

  /// Takes the budget's memory anew, every page written.
  void hold();
  /// After a search: containers grown past the budget give their memory back and hold the
  /// budget again; without a budget nothing changes.
  void settle();
};

}  // namespace palletd

namespace palletd::layout_detail::best_first {

class BestFirstSearch {
 public:
  /// The search's nodes, pool, frontier table and queue live in `storage`, emptied here.
  BestFirstSearch(const PolygonWithHoles& poly, const PolygonWithHoles& edges,
                  const std::vector<BoxFormat>& formats, const LayoutParams& params, const SeamTable* seams,
                  const SearchBudget& budget, double min_outline, const SeedEdgeFilter& seed_ok,
                  SearchMemory::Storage& storage)
      : poly_(poly),
        edges_(edges),
        formats_(formats),
        params_(params),
        seams_(seams),
        budget_(budget),
        min_outline_(min_outline),
        seed_ok_(seed_ok),
        nodes_(storage.nodes),
        pool_(storage.pool),
        frontier_(storage.frontier),
        queue_(storage.queue) {
    nodes_.clear();
    pool_.clear();
    frontier_.clear();
    queue_.clear();
  }

  ComponentSolution run();

 private:
  // Candidates (search_candidates.cpp).
  bool build(std::string* reason);
  std::vector<double> collect_shapes(double* min_short_m);
  [[nodiscard]] EdgeSeeds seed_edges(double min_edge_m) const;
  void seed_ring(const Ring2d& ring, bool hole, double min_edge_m, EdgeSeeds* seeds) const;
  void place_lines(const EdgeSeeds& seeds, const std::vector<double>& dims, double grow_m, bool* capped);
  std::vector<double> measure_cells();
  void build_placements(const std::vector<double>& sat, double grow_m);
  [[nodiscard]] double seam_penalty(const Rect& r, const AreaOracle* mask) const;
  void measure_future_costs(const std::vector<double>& sat);

  // Best-first search (search_best_first.cpp).
  void start_search();
  void search_best_first(ComponentSolution* sol);
  bool take_complete(int k, ComponentSolution* sol);
  void expand(const QueueItem& item, int cell);
  void admit_child(std::size_t idx);
  bool dominated(const Node& child, std::size_t idx);
  void drop_last_node();
  std::size_t make_child(int k, int pi);
  /// Greedy dive from node k: the first fitting placement of each cell (of `format` only, or
  /// of any format for -1; of shape `shape` only, or of any shape for -1).
  void dive(int k, int format, int shape = -1);
  [[nodiscard]] double score_of(int k) const;
  /// The node's upper bound of any completion's score (future: search_future.cpp) [m^2].
  [[nodiscard]] double bound_of(const Node& n) const {
    return total_area_ - n.lost - n.penalty - std::max(0.0, n.future - kFutureSlackM2);
  }
  [[nodiscard]] double floor_score() const;
  void fill_solution(ComponentSolution* sol);

  // Node state (search_state.cpp).
  void advance(Node& n, std::uint64_t* occ) const;
  /// Whether any placement of `cell` fits the occupancy.
  [[nodiscard]] bool fits_any(const std::uint64_t* occ, int cell) const;
  std::vector<FrameBox> boxes_of(int node) const;
  std::uint64_t* occ(std::size_t node) { return pool_.data() + node * words_; }
  /// Key of a node's frontier: its cursor and the occupancy from the cursor on. Two nodes with
  /// the same key have the same futures; only their pasts (covered area) differ.
  [[nodiscard]] std::uint64_t frontier_key(const Node& n, const std::uint64_t* o) const;

  const PolygonWithHoles& poly_;
  const PolygonWithHoles& edges_;
  const std::vector<BoxFormat>& formats_;
  const LayoutParams& params_;
  const SeamTable* seams_;
  const SearchBudget& budget_;
  double min_outline_;  ///< layouts covering less than this [m^2] are pruned
  const SeedEdgeFilter& seed_ok_;

  std::vector<double> xs_, ys_;
  int nx_ = 0, ny_ = 0;
  std::vector<double> cell_area_;
  std::vector<Shape> shapes_;
  std::vector<std::vector<Placement>> placements_;  ///< per cell
  /// Per cell: the least end column of its placements (nx_ + 1 without any): no placement fits
  /// where the cell's row is free for fewer columns than that.
  std::vector<int> nearest_far_side_;
  /// Per cell: the least cost it can still add to a layout, lost (its area) or covered (its share
  /// of the least penalty per area of a placement over it) [m^2].
  std::vector<double> future_cost_;
  double total_area_ = 0, min_box_area_ = 0, tol_ = 0;
  double min_placement_area_ = 0;  ///< least Area(box ∩ layer) of any placement [m^2]
  std::size_t words_ = 0;
  std::vector<Node>& nodes_;
  std::vector<std::uint64_t>& pool_;

  // Best-first search state.
  std::size_t max_nodes_ = 0;
  double tie_margin_m2_ = 0;  ///< scores closer than this tie [m^2]
  double same_tol_m_ = 0;     ///< box centres closer than this are the same box [m]
  FrontierTable& frontier_;
  std::vector<char> fitting_;  ///< expand(): which placements of the cell fit (scratch)
  SearchQueue& queue_;
  int best_ = -1;       ///< the best complete layout (popped, or the incumbent), -1 = none yet
  int runner_ = -1;     ///< first kept alternative, -1 = none
  int best_seen_ = 0;   ///< highest score over all generated nodes (the paper's H_max)
  int incumbent_ = -1;  ///< best complete node of the greedy dives, -1 = none
  std::vector<FrameBox> best_boxes_;
  std::size_t pops_ = 0;
  bool exhausted_ = false;
  bool clock_ran_out_ = false;  ///< the deadline ended the search (exhausted_ too)
};

}  // namespace palletd::layout_detail::best_first
