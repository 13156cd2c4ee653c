// Product layout search, the bound's look-ahead. Every undecided cell ends either lost (it costs
// its area) or covered by one placement, which costs that placement's seam penalty. Spread over
// the placement's cells by area, the penalty charges each cell at least its area times the least
// penalty per area of any placement over the cell. Summed over the undecided cells, the smaller
// of the two is a lower bound of the cost still to come, so total - lost - penalty - future stays
// an upper bound of every completion's score: the bound stays admissible and the search exact,
// while nodes whose remaining cells can only be filled at a cost drop behind the layouts that
// have paid it already.
#include <algorithm>
#include <limits>

#include "search/best_first_internal.hpp"

namespace palletd::layout_detail::best_first {

namespace {

constexpr double kNoPlacement = std::numeric_limits<double>::infinity();

/// The least value stamped over each cell of one row. An interval [a, b) stamps two blocks of
/// the largest power of two that fits in it; resolving pushes each level's blocks down to the
/// cells, so a row of n cells costs O(n log n) however many intervals it takes.
class RowMinima {
 public:
  explicit RowMinima(int cells) : n_(static_cast<std::size_t>(cells)) {
    while ((std::size_t{1} << levels_) <= n_) ++levels_;
    table_.assign(levels_ * n_, kNoPlacement);
  }

  void stamp(int a, int b, double v) {
    const int k = 31 - __builtin_clz(static_cast<unsigned>(b - a));
    take(static_cast<std::size_t>(k), static_cast<std::size_t>(a), v);
    take(static_cast<std::size_t>(k), static_cast<std::size_t>(b - (1 << k)), v);
  }

  /// Writes each cell's least stamp to out[0 .. n) and empties the row for the next.
  void resolve(double* out) {
    for (std::size_t k = levels_ - 1; k > 0; --k) {
      const std::size_t half = std::size_t{1} << (k - 1);
      for (std::size_t x = 0; x + (std::size_t{1} << k) <= n_; ++x) {
        const double v = table_[k * n_ + x];
        take(k - 1, x, v);
        take(k - 1, x + half, v);
      }
    }
    std::copy(table_.begin(), table_.begin() + static_cast<std::ptrdiff_t>(n_), out);
    std::fill(table_.begin(), table_.end(), kNoPlacement);
  }

 private:
  void take(std::size_t level, std::size_t x, double v) {
    double& slot = table_[level * n_ + x];
    slot = std::min(slot, v);
  }

  std::size_t n_;
  std::size_t levels_ = 1;
  std::vector<double> table_;
};

/// A placement while the row sweep is within its rows.
struct Span {
  int i0, i1, j1;
  double per_m2;  ///< its penalty per area of its cells
};

}  // namespace

// future_cost_ per cell and each placement's sum of it (Placement::future).
void BestFirstSearch::measure_future_costs(const std::vector<double>& sat) {
  const auto stride = static_cast<std::size_t>(nx_ + 1);
  const auto ncells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
  if (seams_ == nullptr || seams_->empty()) {
    future_cost_.assign(ncells, 0.0);
    return;
  }
  // The least penalty per area of the placements over each cell, one row at a time.
  std::vector<double> least(ncells, kNoPlacement);
  std::vector<Span> spans;
  RowMinima row(nx_);
  for (int j = 0; j < ny_; ++j) {
    for (int i = 0; i < nx_; ++i) {
      for (const Placement& p : placements_[static_cast<std::size_t>(j * nx_ + i)]) {
        const double cells_m2 = sat_area(sat, stride, i, j, p.i1, p.j1);
        spans.push_back({i, p.i1, p.j1, p.penalty / std::max(p.area, cells_m2)});
      }
    }
    spans.erase(std::remove_if(spans.begin(), spans.end(), [j](const Span& s) { return s.j1 <= j; }),
                spans.end());
    for (const Span& s : spans) row.stamp(s.i0, s.i1, s.per_m2);
    row.resolve(least.data() + static_cast<std::size_t>(j) * static_cast<std::size_t>(nx_));
  }
  future_cost_.resize(ncells);
  std::vector<double> future_sat(sat.size(), 0.0);
  for (int j = 0; j < ny_; ++j) {
    double row_sum = 0.0;
    for (int i = 0; i < nx_; ++i) {
      const auto c = static_cast<std::size_t>(j * nx_ + i);
      future_cost_[c] = cell_area_[c] * std::min(1.0, least[c]);
      row_sum += future_cost_[c];
      future_sat[static_cast<std::size_t>(j + 1) * stride + static_cast<std::size_t>(i) + 1] =
          future_sat[static_cast<std::size_t>(j) * stride + static_cast<std::size_t>(i) + 1] + row_sum;
    }
  }
  for (int j = 0; j < ny_; ++j) {
    for (int i = 0; i < nx_; ++i) {
      for (Placement& p : placements_[static_cast<std::size_t>(j * nx_ + i)])
        p.future = std::max(0.0, sat_area(future_sat, stride, i, j, p.i1, p.j1));
    }
  }
}

}  // namespace palletd::layout_detail::best_first
