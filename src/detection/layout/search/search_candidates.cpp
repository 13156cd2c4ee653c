// Product layout search, candidate generation: candidate box-edge lines from the outline's
// axis-aligned edges, the cell grid with exact cell areas, and every box placement per cell.
#include <algorithm>
#include <cmath>
#include <memory>
#include <set>

#include "search/search_product_internal.hpp"

namespace palletd::layout_detail::product {

/// Candidate lines on one axis: seeds closed under adding every (signed) box side, merged within tol.
std::vector<double> close_lines(std::vector<std::pair<double, double>> seeds /* (pos, weight) */,
                                const std::vector<double>& dims, double lo, double hi, double tol,
                                bool* capped) {
  std::sort(seeds.begin(), seeds.end());
  std::vector<double> merged;
  for (std::size_t i = 0; i < seeds.size();) {
    double sw = 0, s = 0;
    std::size_t j = i;
    while (j < seeds.size() && seeds[j].first - seeds[i].first <= tol) {
      s += seeds[j].first * seeds[j].second;
      sw += seeds[j].second;
      ++j;
    }
    merged.push_back(s / sw);
    i = j;
  }
  std::set<double> lines(merged.begin(), merged.end());
  std::vector<double> frontier = merged;
  auto near_existing = [&](double v) {
    auto it = lines.lower_bound(v - tol);
    return it != lines.end() && *it <= v + tol;
  };
  while (!frontier.empty()) {
    std::vector<double> next;
    for (double v : frontier) {
      for (double d : dims) {
        for (double w : {v + d}) {
          if (w < lo - tol || w > hi + tol || near_existing(w)) continue;
          lines.insert(w);
          next.push_back(w);
          if (lines.size() > kMaxLinesPerAxis) {
            *capped = true;
            return {lines.begin(), lines.end()};
          }
        }
      }
    }
    frontier.swap(next);
  }
  return {lines.begin(), lines.end()};
}

/// Index of the line nearest to v within tol, or -1.
int find_line(const std::vector<double>& lines, double v, double tol) {
  auto it = std::lower_bound(lines.begin(), lines.end(), v - tol);
  int best = -1;
  double best_d = tol;
  for (; it != lines.end() && *it <= v + tol; ++it) {
    const double d = std::abs(*it - v);
    if (d <= best_d) {
      best_d = d;
      best = static_cast<int>(it - lines.begin());
    }
  }
  return best;
}

bool ProductSearch::build(std::string* reason) {
  double min_short = 1e9;
  std::vector<double> dims;
  for (std::size_t f = 0; f < formats_.size(); ++f) {
    const auto& fm = formats_[f];
    min_short = std::min(min_short, fm.short_m);
    dims.push_back(fm.long_m);
    dims.push_back(fm.short_m);
    shapes_.push_back({fm.long_m, fm.short_m, static_cast<int>(f), true});
    if (fm.long_m - fm.short_m > 1e-6) shapes_.push_back({fm.short_m, fm.long_m, static_cast<int>(f), false});
  }
  std::sort(dims.begin(), dims.end());
  dims.erase(std::unique(dims.begin(), dims.end(), [](double a, double b) { return b - a < 1e-6; }),
             dims.end());
  min_box_area_ = 1e9;
  for (const auto& fm : formats_) min_box_area_ = std::min(min_box_area_, fm.long_m * fm.short_m);
  tol_ = line_merge_tol_m(params_, min_short);
  const double min_edge = min_corner_edge_m(min_short);
  const double axis_tol = 5.0 * M_PI / 180.0;

  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const auto& p : poly_.outer) {
    bx0 = std::min(bx0, p.x()); bx1 = std::max(bx1, p.x());
    by0 = std::min(by0, p.y()); by1 = std::max(by1, p.y());
  }
  // Seed edges by the side the layer lies on: boxes start at an edge with layer on its +x side
  // and stack towards +x (and the mirror image), so lines are closed under +dims from the one
  // and -dims from the other. Closing both ways from every edge would add differences of box
  // sides (e.g. 315 - 232 mm) and fill the layer with near-useless lines.
  std::vector<std::pair<double, double>> sx[2], sy[2];  // [0]: layer on the + side, [1]: on the - side
  auto seed_ring = [&](const Ring2d& ring, bool hole) {
    const std::size_t n = ring.size();
    const double orient = (signed_area(ring) >= 0 ? 1.0 : -1.0) * (hole ? -1.0 : 1.0);  // +1: layer on the left
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d a = ring[i], b = ring[(i + 1) % n];
      const double len = (b - a).norm();
      if (len < min_edge) continue;
      const double ang = std::atan2(std::abs(b.y() - a.y()), std::abs(b.x() - a.x()));
      // Left of the direction (dx, dy) is (-dy, dx); the layer lies there when orient > 0.
      if (seed_ok_ && !seed_ok_(a, b, orient * Eigen::Vector2d(b.y() - a.y(), a.x() - b.x()) / len)) continue;
      if (ang < axis_tol) sy[orient * (b.x() - a.x()) > 0 ? 0 : 1].emplace_back((a.y() + b.y()) / 2, len);
      if (ang > M_PI / 2 - axis_tol) sx[orient * (a.y() - b.y()) > 0 ? 0 : 1].emplace_back((a.x() + b.x()) / 2, len);
    }
  };
  seed_ring(edges_.outer, false);
  for (const auto& h : edges_.holes) seed_ring(h, true);
  if ((sx[0].empty() && sx[1].empty()) || (sy[0].empty() && sy[1].empty())) {
    *reason = "the outline has no edge along the layout axes";
    return false;
  }
  bool capped = false;
  std::vector<double> neg_dims;
  for (double d : dims) neg_dims.push_back(-d);
  auto close_both = [&](std::vector<std::pair<double, double>>* seeds, double lo, double hi) {
    std::vector<double> a = close_lines(seeds[0], dims, lo, hi, tol_, &capped);
    const std::vector<double> b = close_lines(seeds[1], neg_dims, lo, hi, tol_, &capped);
    // Union, merged within the tolerance (a line from each side of the same gap is one line).
    std::vector<std::pair<double, double>> all;
    for (double v : a) all.emplace_back(v, 1.0);
    for (double v : b) all.emplace_back(v, 1.0);
    std::sort(all.begin(), all.end());
    std::vector<double> out;
    for (std::size_t i = 0; i < all.size();) {
      std::size_t j = i;
      double sum = 0;
      while (j < all.size() && all[j].first - all[i].first <= tol_) sum += all[j++].first;
      out.push_back(sum / static_cast<double>(j - i));
      i = j;
    }
    return out;
  };
  // Box sides may lie up to the outline's tolerance beyond its extent (a lone box at a coarse
  // pitch measures short by its mixed edge pixels).
  const double grow_m = std::max(0.0, params_.outline_tolerance_m);
  xs_ = close_both(sx, bx0 - grow_m, bx1 + grow_m);
  ys_ = close_both(sy, by0 - grow_m, by1 + grow_m);
  if (capped) {
    *reason = "too many candidate box positions for these formats";
    return false;
  }
  nx_ = static_cast<int>(xs_.size()) - 1;
  ny_ = static_cast<int>(ys_.size()) - 1;
  if (nx_ < 1 || ny_ < 1) {
    *reason = "the layer is smaller than every box format";
    return false;
  }
  const auto ncells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
  cell_area_.assign(ncells, 0.0);
  // Exact cell areas, clipped once; row sums give O(1) box areas through a summed-area table.
  std::vector<double> sat((static_cast<std::size_t>(nx_) + 1) * (static_cast<std::size_t>(ny_) + 1), 0.0);
  const auto W = static_cast<std::size_t>(nx_ + 1);
  const bool grid = params_.area_method == AreaMethod::grid_sat;
  for (int j = 0; j < ny_; ++j) {
    double row = 0;
    for (int i = 0; i < nx_; ++i) {
      const double a = clipped_area(poly_, xs_[static_cast<std::size_t>(i)], ys_[static_cast<std::size_t>(j)],
                                    xs_[static_cast<std::size_t>(i) + 1], ys_[static_cast<std::size_t>(j) + 1]);
      cell_area_[static_cast<std::size_t>(j) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(i)] = a;
      row += a;
      sat[(static_cast<std::size_t>(j) + 1) * W + static_cast<std::size_t>(i) + 1] =
          sat[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(i) + 1] + row;
    }
  }
  total_area_ = 0;
  for (double a : cell_area_) total_area_ += a;
  std::unique_ptr<AreaOracle> oracle;
  if (!grid) oracle = std::make_unique<AreaOracle>(poly_, params_.area_method, params_.area_raster_cell_m);

  std::unique_ptr<AreaOracle> mask;  // fast strip areas for the edge evidence
  if (seams_ != nullptr && !seams_->empty()) {
    mask = std::make_unique<AreaOracle>(poly_, AreaMethod::raster, seams_->cell());
  }
  // The a_min test on the outline grown by its uncertainty (LayoutParams::outline_tolerance_m),
  // rasterised only when a placement is short of a_min by less than the growth can add.
  std::unique_ptr<AreaOracle> grown;
  auto on_layer = [&](const Rect& r, double a, double need) {
    if (a > need) return true;
    const double w = r.x1 - r.x0, h = r.y1 - r.y0;
    if (!(grow_m > 0.0) || a + 2.0 * grow_m * (w + h) + 4.0 * grow_m * grow_m <= need) return false;
    if (!grown) {
      grown = std::make_unique<AreaOracle>(poly_, AreaMethod::raster, std::min(params_.area_raster_cell_m, grow_m),
                                           grow_m);
    }
    return grown->area(r) > need;
  };
  placements_.assign(ncells, {});
  min_placement_area_ = total_area_;
  const double margin = params_.seam_margin_m;
  for (int j = 0; j < ny_; ++j) {
    for (int i = 0; i < nx_; ++i) {
      auto& list = placements_[static_cast<std::size_t>(j) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(i)];
      for (std::size_t k = 0; k < shapes_.size(); ++k) {
        const Shape& s = shapes_[k];
        const int i1 = find_line(xs_, xs_[static_cast<std::size_t>(i)] + s.dx, tol_);
        const int j1 = find_line(ys_, ys_[static_cast<std::size_t>(j)] + s.dy, tol_);
        if (i1 <= i || j1 <= j) continue;
        const Rect r{xs_[static_cast<std::size_t>(i)], ys_[static_cast<std::size_t>(j)],
                     xs_[static_cast<std::size_t>(i1)], ys_[static_cast<std::size_t>(j1)]};
        double a;
        if (grid) {
          a = sat[static_cast<std::size_t>(j1) * W + static_cast<std::size_t>(i1)] -
              sat[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(i1)] -
              sat[static_cast<std::size_t>(j1) * W + static_cast<std::size_t>(i)] +
              sat[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(i)];
        } else {
          a = oracle->area(r);
        }
        if (!on_layer(r, a, params_.a_min_fraction * s.dx * s.dy)) continue;
        double pen = 0;
        if (seams_ != nullptr && !seams_->empty()) {
          // Seams across the interior, and edges with a neighbour that lie on no seam.
          pen = params_.seam_weight * seams_->mass({r.x0 + margin, r.y0 + margin, r.x1 - margin, r.y1 - margin});
          const EdgeEvidence ev = edge_evidence(r, *seams_, [&](const Rect& q) { return mask->area(q); }, margin);
          pen += params_.seam_weight * params_.missing_seam_weight * (ev.neighbour_len - ev.supported_len) * seams_->cell();
        }
        list.push_back({static_cast<int>(k), i1, j1, a, pen});
        min_placement_area_ = std::min(min_placement_area_, a);
      }
      // Most promising first (largest net gain).
      std::sort(list.begin(), list.end(), [](const Placement& a, const Placement& b) {
        return a.area - a.penalty > b.area - b.penalty;
      });
    }
  }
  words_ = (ncells + 63) / 64;
  return true;
}

}  // namespace palletd::layout_detail::product
