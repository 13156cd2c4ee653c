// Product layout search: candidate lines, exact cell areas, bottom-left canonical filling,
// best-first on an admissible bound, runner-up for the ambiguity test.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <queue>
#include <set>
#include <unordered_map>

#include "layout_internal.hpp"

namespace palletd::layout_detail {

namespace {

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
                const LayoutParams& params, const SeamTable* seams, const Deadline& deadline, double min_outline)
      : poly_(poly), edges_(edges), formats_(formats), params_(params), seams_(seams), deadline_(deadline),
        min_outline_(min_outline) {}

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
  const Deadline& deadline_;
  double min_outline_;  ///< layouts covering less than this [m^2] are pruned

  std::vector<double> xs_, ys_;
  int nx_ = 0, ny_ = 0;
  std::vector<double> cell_area_;
  std::vector<Shape> shapes_;
  std::vector<std::vector<Placement>> placements_;  ///< per cell
  double total_area_ = 0, min_box_area_ = 0, tol_ = 0;
  std::size_t words_ = 0;
  std::vector<Node> nodes_;
  std::vector<std::uint64_t> pool_;
};

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
  tol_ = params_.line_merge_tol_m > 0 ? params_.line_merge_tol_m : std::clamp(0.06 * min_short, 0.006, 0.02);
  const double min_edge = std::max(0.02, 0.25 * min_short);
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
      // Left of the direction (dx, dy) is (-dy, dx).
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
  xs_ = close_both(sx, bx0, bx1);
  ys_ = close_both(sy, by0, by1);
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
  placements_.assign(ncells, {});
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
        if (a <= params_.a_min_fraction * s.dx * s.dy) continue;
        double pen = 0;
        if (seams_ != nullptr && !seams_->empty()) {
          // Seams across the interior, and edges with a neighbour that lie on no seam.
          pen = params_.seam_weight * seams_->mass({r.x0 + margin, r.y0 + margin, r.x1 - margin, r.y1 - margin});
          const EdgeEvidence ev = edge_evidence(r, *seams_, [&](const Rect& q) { return mask->area(q); }, margin);
          pen += params_.seam_weight * params_.missing_seam_weight * (ev.neighbour_len - ev.supported_len) * seams_->cell();
        }
        list.push_back({static_cast<int>(k), i1, j1, a, pen});
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

std::uint64_t ProductSearch::frontier_key(const Node& n, const std::uint64_t* o) const {
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

bool ProductSearch::range_free(const std::uint64_t* occ, int start, int len) const {
  int pos = start;
  const int end = start + len;
  while (pos < end) {
    const int w = pos >> 6, b = pos & 63;
    const int n = std::min(64 - b, end - pos);
    const std::uint64_t mask = (n == 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << n) - 1)) << b;
    if ((occ[w] & mask) != 0) return false;
    pos += n;
  }
  return true;
}

void ProductSearch::set_range(std::uint64_t* occ, int start, int len) {
  int pos = start;
  const int end = start + len;
  while (pos < end) {
    const int w = pos >> 6, b = pos & 63;
    const int n = std::min(64 - b, end - pos);
    const std::uint64_t mask = (n == 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << n) - 1)) << b;
    occ[w] |= mask;
    pos += n;
  }
}

bool ProductSearch::fits(const std::uint64_t* occ, int cell, const Placement& p) const {
  const int i = cell % nx_, j = cell / nx_;
  for (int row = j; row < p.j1; ++row) {
    if (!range_free(occ, row * nx_ + i, p.i1 - i)) return false;
  }
  return true;
}

void ProductSearch::advance(Node& n, std::uint64_t* occ) const {
  const int ncells = nx_ * ny_;
  const double stop_area = params_.a_min_fraction * min_box_area_;
  while (n.cursor < ncells) {
    const double remaining = total_area_ - n.covered - n.lost;
    if (remaining < stop_area) {  // no further box can be placed: the rest is lost
      n.lost += std::max(0.0, remaining);
      n.cursor = ncells;
      break;
    }
    const int c = n.cursor;
    if ((occ[c >> 6] >> (c & 63)) & 1U) {
      ++n.cursor;
      continue;
    }
    bool any = false;
    for (const auto& p : placements_[static_cast<std::size_t>(c)]) {
      if (fits(occ, c, p)) {
        any = true;
        break;
      }
    }
    if (any) break;
    occ[c >> 6] |= std::uint64_t{1} << (c & 63);  // forced: nothing fits here
    n.lost += cell_area_[static_cast<std::size_t>(c)];
    ++n.cursor;
  }
  n.complete = n.cursor >= ncells;
}

std::vector<FrameBox> ProductSearch::boxes_of(int node) const {
  std::vector<FrameBox> out;
  for (int k = node; k >= 0; k = nodes_[static_cast<std::size_t>(k)].parent) {
    const Node& n = nodes_[static_cast<std::size_t>(k)];
    if (n.placement < 0) continue;
    const Placement& p = placements_[static_cast<std::size_t>(n.cell)][static_cast<std::size_t>(n.placement)];
    const int i = n.cell % nx_, j = n.cell / nx_;
    const Shape& s = shapes_[static_cast<std::size_t>(p.shape)];
    out.push_back({{xs_[static_cast<std::size_t>(i)], ys_[static_cast<std::size_t>(j)],
                    xs_[static_cast<std::size_t>(p.i1)], ys_[static_cast<std::size_t>(p.j1)]},
                   s.format, s.long_along_x});
  }
  std::reverse(out.begin(), out.end());
  return out;
}

ComponentSolution ProductSearch::run() {
  ComponentSolution sol;
  if (!build(&sol.reason)) return sol;
  const std::size_t max_nodes =
      std::max<std::size_t>(16, std::min(params_.max_nodes, kMaxPoolBytes / (words_ * 8)));
  nodes_.reserve(std::min<std::size_t>(max_nodes, 1 << 16));
  pool_.reserve(std::min<std::size_t>(max_nodes, 1 << 16) * words_);
  const double margin = params_.ambiguity_margin * min_box_area_;
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
    if ((++pops & 127U) == 0 && deadline_.passed()) {
      exhausted = true;
      break;
    }
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

}  // namespace

ComponentSolution search_product(const PolygonWithHoles& frame_polygon, const PolygonWithHoles& frame_edges,
                                 const std::vector<BoxFormat>& formats, const LayoutParams& params,
                                 const SeamTable* seams, const Deadline& deadline, double min_outline_score) {
  ProductSearch search(frame_polygon, frame_edges, formats, params, seams, deadline, min_outline_score);
  return search.run();
}

}  // namespace palletd::layout_detail
