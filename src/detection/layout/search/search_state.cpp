// Product layout search, node state: occupancy bits of the cell grid, the canonical frontier
// key (two nodes with the same key have the same futures), forced cells, layouts of nodes.
#include <algorithm>

#include "search/best_first_internal.hpp"

namespace palletd::layout_detail::best_first {

std::uint64_t BestFirstSearch::frontier_key(const Node& n, const std::uint64_t* o) const {
  std::uint64_t h = 1469598103934665603ULL ^ static_cast<std::uint64_t>(n.cursor);
  const auto first = static_cast<std::size_t>(n.cursor >> 6);
  for (std::size_t w = first; w < words_; ++w) {
    std::uint64_t v = o[w];
    if (w == first) v &= ~std::uint64_t{0} << (n.cursor & 63);  // bits below the cursor are decided
    h ^= v + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    h *= 1099511628211ULL;
  }
  return h;
}

void BestFirstSearch::advance(Node& n, std::uint64_t* occ) const {
  const int ncells = nx_ * ny_;
  // No placement covers less of the layer than this (with an outline tolerance, less than
  // a_min_fraction of a box can be enough).
  const double stop_area = std::min(params_.search.a_min_fraction * min_box_area_, min_placement_area_);
  const auto remaining = [this, &n] { return total_area_ - n.covered - n.lost; };
  const auto lose_the_rest = [&n, ncells](double rest) {
    n.lost += std::max(0.0, rest);
    n.future = 0.0;
    n.cursor = ncells;
  };
  while (n.cursor < ncells) {
    if (remaining() < stop_area) {  // no further box can be placed: the rest is lost
      lose_the_rest(remaining());
      break;
    }
    const int c = next_free_bit(occ, n.cursor, ncells);  // covered cells are decided
    n.cursor = c;
    if (c >= ncells) break;
    // The free run along the cursor's row, [c, run_last). Each placement needs its cell's row free
    // up to its far side, so a cell whose nearest far side lies beyond the run's end is forced
    // without reading the grid; the run's forced cells are marked at once.
    const int i = c % nx_;
    const int run_end = i + free_bits_from(occ, c, nx_ - i);
    const int run_last = c + (run_end - i);
    int k = c;
    for (; k < run_last; ++k) {
      if (k > c && remaining() < stop_area) break;
      if (run_end >= nearest_far_side_[static_cast<std::size_t>(k)] && fits_any(occ, k)) break;
      n.lost += cell_area_[static_cast<std::size_t>(k)];  // forced: nothing fits here
      n.future -= future_cost_[static_cast<std::size_t>(k)];
    }
    if (k > c) set_range(occ, c, k - c);
    n.cursor = k;
    if (k < run_last) {
      if (remaining() < stop_area) lose_the_rest(remaining());
      break;  // a placement fits at k (or nothing more can be placed)
    }
  }
  n.complete = n.cursor >= ncells;
  if (n.complete) n.future = 0.0;
  n.future = std::max(0.0, n.future);
}

bool BestFirstSearch::fits_any(const std::uint64_t* occ, int cell) const {
  FreeRuns runs(occ, cell, nx_);
  const auto& list = placements_[static_cast<std::size_t>(cell)];
  return std::any_of(list.begin(), list.end(), [&runs](const Placement& p) { return runs.fits(p); });
}

std::vector<FrameBox> BestFirstSearch::boxes_of(int node) const {
  std::vector<FrameBox> out;
  for (int k = node; k >= 0; k = nodes_[static_cast<std::size_t>(k)].parent) {
    const Node& n = nodes_[static_cast<std::size_t>(k)];
    if (n.placement < 0) continue;
    const int cell = nodes_[static_cast<std::size_t>(n.parent)].cursor;  // the cell this step decided
    const Placement& p = placements_[static_cast<std::size_t>(cell)][static_cast<std::size_t>(n.placement)];
    const int i = cell % nx_, j = cell / nx_;
    const Shape& s = shapes_[static_cast<std::size_t>(p.shape)];
    out.push_back({{xs_[static_cast<std::size_t>(i)], ys_[static_cast<std::size_t>(j)],
                    xs_[static_cast<std::size_t>(p.i1)], ys_[static_cast<std::size_t>(p.j1)]},
                   s.format, s.long_along_x});
  }
  std::reverse(out.begin(), out.end());
  return out;
}

void FrontierTable::clear() {
  size_ = 0;
  if (++stamp_ == 0) {  // the stamps wrapped: no slot may look like this search's
    for (Slot& slot : slots_) slot.stamp = 0;
    stamp_ = 1;
  }
}

void FrontierTable::hold(std::size_t n) {
  std::vector<Slot>().swap(slots_);
  size_ = 0;
  std::size_t slots = 1024;
  while (slots < 2 * n) slots *= 2;
  resize(slots);  // value-initialised: every page written
}

void FrontierTable::resize(std::size_t slots) {
  std::vector<Slot> old(slots);
  old.swap(slots_);
  mask_ = slots - 1;
  shift_ = 64 - __builtin_ctzll(slots);
  for (const Slot& slot : old) {
    if (slot.stamp != stamp_) continue;
    std::size_t i = index(slot.key);
    while (slots_[i].stamp == stamp_) i = (i + 1) & mask_;
    slots_[i] = slot;
  }
}

}  // namespace palletd::layout_detail::best_first
