// Product layout search, candidate generation: candidate box-edge lines from the outline's
// axis-aligned edges, the cell grid with exact cell areas, and every box placement per cell.
#include <algorithm>
#include <cmath>
#include <memory>
#include <set>

#include "search/best_first_internal.hpp"

namespace palletd::layout_detail::best_first {

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

namespace {

constexpr double kNoSideYetM = 1e9;       ///< shortest box side before any format [m]
constexpr double kNoAreaYetM2 = 1e9;      ///< smallest box area before any format [m^2]
constexpr double kSameSideTolM = 1e-6;    ///< box sides closer than this are one side [m]
constexpr double kAxisTolDeg = 5.0;       ///< edges this close to a layout axis seed lines [deg]
constexpr std::size_t kBitsPerWord = 64;  ///< cells per occupancy word

/// Bounding rectangle of a ring (x0 = y0 = 1e300, x1 = y1 = -1e300 when it is empty).
Rect ring_bounds(const Ring2d& ring) {
  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const auto& p : ring) {
    bx0 = std::min(bx0, p.x());
    bx1 = std::max(bx1, p.x());
    by0 = std::min(by0, p.y());
    by1 = std::max(by1, p.y());
  }
  return {bx0, by0, bx1, by1};
}

/// Lines of one axis in [lo, hi]: the seeds with the layer on the + side closed under +dims, those
/// with the layer on the - side under -dims; the union merged within tol (a line from each side of
/// the same gap is one line).
std::vector<double> close_both(const AxisSeeds& seeds, const std::vector<double>& dims,
                               const std::vector<double>& neg_dims, double lo, double hi, double tol,
                               bool* capped) {
  std::vector<double> a = close_lines(seeds.plus, dims, lo, hi, tol, capped);
  const std::vector<double> b = close_lines(seeds.minus, neg_dims, lo, hi, tol, capped);
  std::vector<std::pair<double, double>> all;
  for (double v : a) all.emplace_back(v, 1.0);
  for (double v : b) all.emplace_back(v, 1.0);
  std::sort(all.begin(), all.end());
  std::vector<double> out;
  for (std::size_t i = 0; i < all.size();) {
    std::size_t j = i;
    double sum = 0;
    while (j < all.size() && all[j].first - all[i].first <= tol) sum += all[j++].first;
    out.push_back(sum / static_cast<double>(j - i));
    i = j;
  }
  return out;
}

/// The a_min test on the outline grown by its uncertainty (LayoutParams::outline_tolerance_m),
/// rasterised only when a placement is short of a_min by less than the growth can add.
class GrownLayerTest {
 public:
  GrownLayerTest(const PolygonWithHoles& poly, double raster_cell_m, double grow_m)
      : poly_(&poly), raster_cell_m_(raster_cell_m), grow_m_(grow_m) {}

  /// Whether more than `need` [m^2] of rectangle r lies on the grown layer; `a` is Area(r ∩ layer).
  bool on_layer(const Rect& r, double a, double need) {
    if (a > need) return true;
    const double w = r.x1 - r.x0, h = r.y1 - r.y0;
    if (!(grow_m_ > 0.0) || a + 2.0 * grow_m_ * (w + h) + 4.0 * grow_m_ * grow_m_ <= need) return false;
    if (!grown_) {
      grown_ = std::make_unique<AreaOracle>(*poly_, AreaMethod::kRaster, std::min(raster_cell_m_, grow_m_),
                                            grow_m_);
    }
    return grown_->area(r) > need;
  }

 private:
  const PolygonWithHoles* poly_;
  double raster_cell_m_;
  double grow_m_;
  std::unique_ptr<AreaOracle> grown_;
};

}  // namespace

/// Area of the cell range [i, i1) x [j, j1) from the summed-area table (row stride `stride`).
double sat_area(const std::vector<double>& sat, std::size_t stride, int i, int j, int i1, int j1) {
  return sat[static_cast<std::size_t>(j1) * stride + static_cast<std::size_t>(i1)] -
         sat[static_cast<std::size_t>(j) * stride + static_cast<std::size_t>(i1)] -
         sat[static_cast<std::size_t>(j1) * stride + static_cast<std::size_t>(i)] +
         sat[static_cast<std::size_t>(j) * stride + static_cast<std::size_t>(i)];
}

bool BestFirstSearch::build(std::string* reason) {
  double min_short = kNoSideYetM;
  const std::vector<double> dims = collect_shapes(&min_short);
  tol_ = line_merge_tol_m(params_, min_short);
  const EdgeSeeds seeds = seed_edges(min_corner_edge_m(min_short));
  if (seeds.x.empty() || seeds.y.empty()) {
    *reason = "the outline has no edge along the layout axes";
    return false;
  }
  // Box sides may lie up to the outline's tolerance beyond its extent (a lone box at a coarse
  // pitch measures short by its mixed edge pixels).
  const double grow_m = std::max(0.0, params_.search.outline_tolerance_m);
  bool capped = false;
  place_lines(seeds, dims, grow_m, &capped);
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
  const std::vector<double> sat = measure_cells();
  build_placements(sat, grow_m);
  measure_future_costs(sat);
  words_ = (cell_area_.size() + kBitsPerWord - 1) / kBitsPerWord;
  return true;
}

// Shapes (every format, along x and, when not square, turned), the smallest box area; returns the
// distinct box sides, ascending, and lowers *min_short_m to the shortest box side.
std::vector<double> BestFirstSearch::collect_shapes(double* min_short_m) {
  std::vector<double> dims;
  for (std::size_t f = 0; f < formats_.size(); ++f) {
    const auto& fm = formats_[f];
    *min_short_m = std::min(*min_short_m, fm.short_m);
    dims.push_back(fm.long_m);
    dims.push_back(fm.short_m);
    shapes_.push_back({fm.long_m, fm.short_m, static_cast<int>(f), true});
    if (fm.long_m - fm.short_m > kSameSideTolM) {
      shapes_.push_back({fm.short_m, fm.long_m, static_cast<int>(f), false});
    }
  }
  std::sort(dims.begin(), dims.end());
  dims.erase(std::unique(dims.begin(), dims.end(), [](double a, double b) { return b - a < kSameSideTolM; }),
             dims.end());
  min_box_area_ = kNoAreaYetM2;
  for (const auto& fm : formats_) min_box_area_ = std::min(min_box_area_, fm.long_m * fm.short_m);
  return dims;
}

// Seed edges by the side the layer lies on: boxes start at an edge with layer on its +x side
// and stack towards +x (and the mirror image), so lines are closed under +dims from the one
// and -dims from the other. Closing both ways from every edge would add differences of box
// sides (e.g. 315 - 232 mm) and fill the layer with near-useless lines.
EdgeSeeds BestFirstSearch::seed_edges(double min_edge_m) const {
  EdgeSeeds seeds;
  seed_ring(edges_.outer, false, min_edge_m, &seeds);
  for (const auto& h : edges_.holes) seed_ring(h, true, min_edge_m, &seeds);
  return seeds;
}

// Seeds from the axis-aligned edges of one ring at least min_edge_m long that seed_ok_ accepts:
// edges along x seed y lines, edges along y seed x lines, at their midpoints, weighted by length.
void BestFirstSearch::seed_ring(const Ring2d& ring, bool hole, double min_edge_m, EdgeSeeds* seeds) const {
  const double axis_tol = kAxisTolDeg * M_PI / 180.0;
  const std::size_t n = ring.size();
  const double orient = (signed_area(ring) >= 0 ? 1.0 : -1.0) * (hole ? -1.0 : 1.0);  // +1: layer on the left
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d a = ring[i], b = ring[(i + 1) % n];
    const double len = (b - a).norm();
    if (len < min_edge_m) continue;
    const double ang = std::atan2(std::abs(b.y() - a.y()), std::abs(b.x() - a.x()));
    // Left of the direction (dx, dy) is (-dy, dx); the layer lies there when orient > 0.
    if (seed_ok_ && !seed_ok_(a, b, orient * Eigen::Vector2d(b.y() - a.y(), a.x() - b.x()) / len)) continue;
    if (ang < axis_tol) {
      (orient * (b.x() - a.x()) > 0 ? seeds->y.plus : seeds->y.minus).emplace_back((a.y() + b.y()) / 2, len);
    }
    if (ang > M_PI / 2 - axis_tol) {
      (orient * (a.y() - b.y()) > 0 ? seeds->x.plus : seeds->x.minus).emplace_back((a.x() + b.x()) / 2, len);
    }
  }
}

// Candidate lines xs_, ys_ over the outline's extent grown by grow_m; sets *capped when an axis
// would need more than kMaxLinesPerAxis lines.
void BestFirstSearch::place_lines(const EdgeSeeds& seeds, const std::vector<double>& dims, double grow_m,
                                bool* capped) {
  const Rect b = ring_bounds(poly_.outer);
  std::vector<double> neg_dims;
  for (double d : dims) neg_dims.push_back(-d);
  xs_ = close_both(seeds.x, dims, neg_dims, b.x0 - grow_m, b.x1 + grow_m, tol_, capped);
  ys_ = close_both(seeds.y, dims, neg_dims, b.y0 - grow_m, b.y1 + grow_m, tol_, capped);
}

// Exact cell areas (cell_area_, total_area_), clipped once; returns their summed-area table
// ((ny_ + 1) x (nx_ + 1)), which gives O(1) box areas.
std::vector<double> BestFirstSearch::measure_cells() {
  const auto ncells = static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_);
  cell_area_.assign(ncells, 0.0);
  std::vector<double> sat((static_cast<std::size_t>(nx_) + 1) * (static_cast<std::size_t>(ny_) + 1), 0.0);
  const auto stride = static_cast<std::size_t>(nx_ + 1);
  for (int j = 0; j < ny_; ++j) {
    double row = 0;
    for (int i = 0; i < nx_; ++i) {
      const double a =
          clipped_area(poly_, xs_[static_cast<std::size_t>(i)], ys_[static_cast<std::size_t>(j)],
                       xs_[static_cast<std::size_t>(i) + 1], ys_[static_cast<std::size_t>(j) + 1]);
      const auto cell =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(i);
      cell_area_[cell] = a;
      row += a;
      sat[(static_cast<std::size_t>(j) + 1) * stride + static_cast<std::size_t>(i) + 1] =
          sat[static_cast<std::size_t>(j) * stride + static_cast<std::size_t>(i) + 1] + row;
    }
  }
  total_area_ = 0;
  for (double a : cell_area_) total_area_ += a;
  return sat;
}

// Every placement per cell: each shape from the cell's lower-left corner to the lines its sides
// reach, when enough of it lies on the layer, with its seam penalty; most promising first.
void BestFirstSearch::build_placements(const std::vector<double>& sat, double grow_m) {
  const auto stride = static_cast<std::size_t>(nx_ + 1);
  const bool grid = params_.search.area_method == AreaMethod::kGridSat;
  std::unique_ptr<AreaOracle> oracle;
  if (!grid) oracle = std::make_unique<AreaOracle>(poly_, params_.search.area_method, params_.search.area_raster_cell_m);
  std::unique_ptr<AreaOracle> mask;  // fast strip areas for the edge evidence
  if (seams_ != nullptr && !seams_->empty()) {
    mask = std::make_unique<AreaOracle>(poly_, AreaMethod::kRaster, seams_->cell());
  }
  GrownLayerTest grown(poly_, params_.search.area_raster_cell_m, grow_m);
  placements_.assign(cell_area_.size(), {});
  min_placement_area_ = total_area_;
  for (int j = 0; j < ny_; ++j) {
    for (int i = 0; i < nx_; ++i) {
      auto& list = placements_[static_cast<std::size_t>(j) * static_cast<std::size_t>(nx_) +
                               static_cast<std::size_t>(i)];
      for (std::size_t k = 0; k < shapes_.size(); ++k) {
        const Shape& s = shapes_[k];
        const int i1 = find_line(xs_, xs_[static_cast<std::size_t>(i)] + s.dx, tol_);
        const int j1 = find_line(ys_, ys_[static_cast<std::size_t>(j)] + s.dy, tol_);
        if (i1 <= i || j1 <= j) continue;
        const Rect r{xs_[static_cast<std::size_t>(i)], ys_[static_cast<std::size_t>(j)],
                     xs_[static_cast<std::size_t>(i1)], ys_[static_cast<std::size_t>(j1)]};
        const double a = grid ? sat_area(sat, stride, i, j, i1, j1) : oracle->area(r);
        if (!grown.on_layer(r, a, params_.search.a_min_fraction * s.dx * s.dy)) continue;
        list.push_back({static_cast<int>(k), i1, j1, a, seam_penalty(r, mask.get())});
        min_placement_area_ = std::min(min_placement_area_, a);
      }
      // Most promising first (largest net gain).
      std::sort(list.begin(), list.end(), [](const Placement& a, const Placement& b) {
        return a.area - a.penalty > b.area - b.penalty;
      });
    }
  }
  nearest_far_side_.assign(placements_.size(), nx_ + 1);
  for (std::size_t c = 0; c < placements_.size(); ++c)
    for (const Placement& p : placements_[c]) nearest_far_side_[c] = std::min(nearest_far_side_[c], p.i1);
}

// Seam penalty of a box (0 without seams): seams across the interior, and edges with a neighbour
// that lie on no seam.
double BestFirstSearch::seam_penalty(const Rect& r, const AreaOracle* mask) const {
  if (seams_ == nullptr || seams_->empty()) return 0;
  const double margin = params_.seams.margin_m;
  double pen =
      params_.seams.weight * seams_->mass({r.x0 + margin, r.y0 + margin, r.x1 - margin, r.y1 - margin});
  const auto layer_area = [mask](const Rect& q) { return mask->area(q); };
  const EdgeEvidence ev = edge_evidence(r, *seams_, layer_area, margin);
  pen += params_.seams.weight * params_.seams.missing_weight * (ev.neighbour_len - ev.supported_len) *
         seams_->cell();
  return pen;
}

}  // namespace palletd::layout_detail::best_first
