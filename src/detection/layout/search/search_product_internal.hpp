// Private to the product layout search (search_*.cpp): its cell grid, nodes and the search
// class. Pieces: search_candidates.cpp (candidate lines, cells, placements), search_state.cpp
// (occupancy bits, canonical frontier keys, forced cells), search_product.cpp (best-first queue).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "layout_internal.hpp"

namespace palletd::layout_detail::product {

constexpr std::size_t kMaxLinesPerAxis = 240;
constexpr std::size_t kMaxPoolBytes = std::size_t{96} << 20;

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
};

/// Candidate lines on one axis: seeds closed under adding every (signed) box side, merged within
/// tol. Sets *capped when more than kMaxLinesPerAxis lines would be needed.
std::vector<double> close_lines(std::vector<std::pair<double, double>> seeds /* (pos, weight) */,
                                const std::vector<double>& dims, double lo, double hi, double tol,
                                bool* capped);

/// Index of the line nearest to v within tol, or -1.
int find_line(const std::vector<double>& lines, double v, double tol);

struct Node {
  double covered, lost, penalty;
  int parent;
  int placement;  ///< index into placements of `cell`, -1 = skip, -2 = root
  int cell;       ///< decided cell of this step
  int cursor;     ///< first possibly undecided cell
  bool complete;
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

class ProductSearch {
 public:
  ProductSearch(const PolygonWithHoles& poly, const PolygonWithHoles& edges, const std::vector<BoxFormat>& formats,
                const LayoutParams& params, const SeamTable* seams, const SearchBudget& budget, double min_outline,
                const SeedEdgeFilter& seed_ok)
      : poly_(poly), edges_(edges), formats_(formats), params_(params), seams_(seams), budget_(budget),
        min_outline_(min_outline), seed_ok_(seed_ok) {}

  ComponentSolution run();

 private:
  bool build(std::string* reason);
  [[nodiscard]] bool range_free(const std::uint64_t* occ, int start, int len) const;
  static void set_range(std::uint64_t* occ, int start, int len);
  [[nodiscard]] bool fits(const std::uint64_t* occ, int cell, const Placement& p) const;
  void advance(Node& n, std::uint64_t* occ) const;
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
  double total_area_ = 0, min_box_area_ = 0, tol_ = 0;
  double min_placement_area_ = 0;  ///< least Area(box ∩ layer) of any placement [m^2]
  std::size_t words_ = 0;
  std::vector<Node> nodes_;
  std::vector<std::uint64_t> pool_;
};

}  // namespace palletd::layout_detail::product
