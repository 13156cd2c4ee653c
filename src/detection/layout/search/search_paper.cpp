// Paper mode: Algorithms 1-3 of the paper (Section IV) as published, with a cap.
//
// Reading of the published pseudo-code: the pivot direction d of a box points from its origin
// vertex into the box ("opposite to the original vertex"); stacked boxes go on the two sides of
// B_in away from the pivot, flush with the pivot-side edge, aligned or turned by 90 deg (the
// four ways of Fig. 2), and inherit d. Every box of a hypothesis shares the orientation of its
// initial corner mod 90 deg, so each hypothesis tree is kept in the frame of that corner, where
// boxes are axis-aligned and Area(B ∩ C) is an exact clip.
#include <algorithm>
#include <cmath>
#include <deque>

#include "layout_internal.hpp"

namespace palletd::layout_detail {

namespace {

struct PaperBox {
  Rect rect;
  int format;
  bool long_along_x;
  int ax, ay;  ///< pivot direction (away from the origin vertex) in frame axes, +/-1
};

struct PaperNode {
  PaperBox box;
  int parent;
  int frame;
  double score;
};

constexpr double kNoSideYetM = 1e9;          ///< shortest box side before any format [m]
constexpr double kSamePositionTolM = 1e-9;   ///< candidate boxes with origins closer than this are one [m]
constexpr std::size_t kClockCheckMask = 63;  ///< the deadline is read once every 64 pops

int sign_of(double v) { return v >= 0 ? 1 : -1; }

/// A direction snapped to the nearer frame axis (a unit vector along +/-x or +/-y).
Eigen::Vector2d snap_to_axis(Eigen::Vector2d d) {
  return std::abs(d.x()) >= std::abs(d.y()) ? Eigen::Vector2d(sign_of(d.x()), 0)
                                            : Eigen::Vector2d(0, sign_of(d.y()));
}

/// Mean of the outer ring's vertices (zero when it is empty): the pivot of every corner's frame.
Eigen::Vector2d vertex_mean(const PolygonWithHoles& polygon) {
  Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
  for (const auto& p : polygon.outer) pivot += p;
  if (!polygon.outer.empty()) pivot /= static_cast<double>(polygon.outer.size());
  return pivot;
}

/// The hypothesis trees of Algorithms 1-3: one frame per convex corner, nodes expanded
/// breadth-first, the best-scoring node remembered.
class PaperSearch {
 public:
  PaperSearch(const PolygonWithHoles& polygon, const std::vector<BoxFormat>& formats,
              const LayoutParams& params)
      : polygon_(polygon), formats_(formats), params_(params) {}

  void seed_corner(const Corner& c, const Eigen::Vector2d& pivot);
  [[nodiscard]] bool empty() const { return nodes_.empty(); }
  /// Expands until the queue is empty; returns true when the cap or the deadline stopped it.
  bool expand_all(const Deadline& deadline);
  /// The best hypothesis' boxes in the layer frame, its score and the node count.
  void fill_solution(PaperSolution* sol) const;

 private:
  double area_of(int frame, const Rect& r) const {
    return clipped_area(frame_polys_[static_cast<std::size_t>(frame)], r.x0, r.y0, r.x1, r.y1);
  }
  void push(const PaperNode& n);
  void expand(int k);
  void add_stacked(const PaperBox& in, std::size_t f, int way, int frame);
  [[nodiscard]] bool in_candidates(const PaperBox& nb) const;

  const PolygonWithHoles& polygon_;
  const std::vector<BoxFormat>& formats_;
  const LayoutParams& params_;
  std::vector<LayoutFrame> frames_;
  std::vector<PolygonWithHoles> frame_polys_;  ///< the polygon in each frame
  std::vector<PaperNode> nodes_;
  std::deque<int> queue_;
  int best_ = -1;
  std::vector<PaperBox> hyp_;   ///< boxes of the node being expanded, itself first
  std::vector<PaperBox> cand_;  ///< its distinct stacked boxes
};

void PaperSearch::push(const PaperNode& n) {
  nodes_.push_back(n);
  const int k = static_cast<int>(nodes_.size()) - 1;
  queue_.push_back(k);
  if (best_ < 0 || n.score > nodes_[static_cast<std::size_t>(best_)].score) best_ = k;
}

// Initial hypotheses on one convex orthogonal corner: a new frame along the corner's incoming
// edge, and every format along either edge from the vertex when eq. (2) holds.
void PaperSearch::seed_corner(const Corner& c, const Eigen::Vector2d& pivot) {
  LayoutFrame frame;
  frame.theta_rad = std::atan2(c.v.y() - c.prev.y(), c.v.x() - c.prev.x());
  frame.pivot = pivot;
  frames_.push_back(frame);
  frame_polys_.push_back(frame.to_frame(polygon_));
  const int fi = static_cast<int>(frames_.size()) - 1;
  const Eigen::Vector2d v = frame.to_frame(c.v);
  // e_p, e_n snapped to the frame axes.
  const Eigen::Vector2d ep = snap_to_axis(frame.to_frame(c.prev) - v);
  const Eigen::Vector2d en = snap_to_axis(frame.to_frame(c.next) - v);
  for (std::size_t f = 0; f < formats_.size(); ++f) {
    for (bool on_prev : {true, false}) {
      const Eigen::Vector2d a = on_prev ? ep : en, b = on_prev ? en : ep;
      const double w = formats_[f].long_m, h = formats_[f].short_m;
      const Eigen::Vector2d far = v + a * w + b * h;
      PaperBox box;
      box.rect = {std::min(v.x(), far.x()), std::min(v.y(), far.y()), std::max(v.x(), far.x()),
                  std::max(v.y(), far.y())};
      box.format = static_cast<int>(f);
      box.long_along_x = std::abs(a.x()) > 0.5;
      box.ax = sign_of(far.x() - v.x());
      box.ay = sign_of(far.y() - v.y());
      const double inter = area_of(fi, box.rect);
      if (inter > params_.search.a_min_fraction * w * h) push({box, -1, fi, inter});
    }
  }
}

bool PaperSearch::expand_all(const Deadline& deadline) {
  std::size_t pops = 0;
  while (!queue_.empty()) {
    if (nodes_.size() >= params_.search.paper_max_hypotheses ||
        ((++pops & kClockCheckMask) == 0 && deadline.passed())) {
      return true;
    }
    const int k = queue_.front();
    queue_.pop_front();
    expand(k);
  }
  return false;
}

// One node: FindStackedBoxes for every box of its hypothesis and every format, each distinct
// stacked box a child.
void PaperSearch::expand(int k) {
  const PaperNode cur = nodes_[static_cast<std::size_t>(k)];
  hyp_.clear();
  for (int n = k; n >= 0; n = nodes_[static_cast<std::size_t>(n)].parent) {
    hyp_.push_back(nodes_[static_cast<std::size_t>(n)].box);
  }
  cand_.clear();
  for (const auto& in : hyp_) {
    for (std::size_t f = 0; f < formats_.size(); ++f) {
      for (int way = 0; way < 4; ++way) add_stacked(in, f, way, cur.frame);
    }
  }
  for (const auto& nb : cand_) {
    push({nb, k, cur.frame, cur.score + area_of(cur.frame, nb.rect)});
  }
}

// The box of format f stacked on `in` one of the four ways (bit 0: turned by 90 deg; way < 2:
// beyond the far y edge, else beyond the far x edge), added to cand_ when eq. (2) and (3) hold
// and it is not there yet.
void PaperSearch::add_stacked(const PaperBox& in, std::size_t f, int way, int frame) {
  const bool turned = (way & 1) != 0;
  const bool far_y = way < 2;
  // New box extents along the frame axes: aligned keeps B_in's long axis.
  const bool long_x = turned ? !in.long_along_x : in.long_along_x;
  const double lx = long_x ? formats_[f].long_m : formats_[f].short_m;
  const double ly = long_x ? formats_[f].short_m : formats_[f].long_m;
  PaperBox nb;
  nb.format = static_cast<int>(f);
  nb.long_along_x = long_x;
  nb.ax = in.ax;
  nb.ay = in.ay;
  const Rect& r = in.rect;
  if (far_y) {  // beyond the far y edge, flush with the pivot-side x edge
    nb.rect.x0 = in.ax > 0 ? r.x0 : r.x1 - lx;
    nb.rect.y0 = in.ay > 0 ? r.y1 : r.y0 - ly;
  } else {  // beyond the far x edge, flush with the pivot-side y edge
    nb.rect.x0 = in.ax > 0 ? r.x1 : r.x0 - lx;
    nb.rect.y0 = in.ay > 0 ? r.y0 : r.y1 - ly;
  }
  nb.rect.x1 = nb.rect.x0 + lx;
  nb.rect.y1 = nb.rect.y0 + ly;
  const double box_area = lx * ly;
  if (area_of(frame, nb.rect) <= params_.search.a_min_fraction * box_area) return;  // eq. (2)
  double over = 0;  // eq. (3), Area(B_new ∩ ∪ B_j) bounded by the sum of pairwise overlaps
  for (const auto& b : hyp_) over += overlap(nb.rect, b.rect);
  if (over >= params_.search.a_max_fraction * box_area) return;
  if (!in_candidates(nb)) cand_.push_back(nb);
}

bool PaperSearch::in_candidates(const PaperBox& nb) const {
  for (const auto& c : cand_) {
    if (std::abs(c.rect.x0 - nb.rect.x0) < kSamePositionTolM &&
        std::abs(c.rect.y0 - nb.rect.y0) < kSamePositionTolM && c.long_along_x == nb.long_along_x &&
        c.format == nb.format) {
      return true;
    }
  }
  return false;
}

void PaperSearch::fill_solution(PaperSolution* sol) const {
  sol->visited = nodes_.size();
  const PaperNode& b = nodes_[static_cast<std::size_t>(best_)];
  sol->score = b.score;
  const LayoutFrame& frame = frames_[static_cast<std::size_t>(b.frame)];
  for (int n = best_; n >= 0; n = nodes_[static_cast<std::size_t>(n)].parent) {
    const PaperBox& pb = nodes_[static_cast<std::size_t>(n)].box;
    sol->boxes.push_back(frame.to_layer(FrameBox{pb.rect, pb.format, pb.long_along_x}, formats_));
  }
  std::reverse(sol->boxes.begin(), sol->boxes.end());
  sol->found = !sol->boxes.empty();
}

}  // namespace

PaperSolution search_paper(const PolygonWithHoles& polygon, const PolygonWithHoles& edges,
                           const std::vector<BoxFormat>& formats, const LayoutParams& params,
                           const Deadline& deadline) {
  PaperSolution sol;
  double min_short = kNoSideYetM;
  for (const auto& f : formats) min_short = std::min(min_short, f.short_m);
  const double min_edge = min_corner_edge_m(min_short);
  const std::vector<Corner> corners = orthogonal_corners(edges, params.search.corner_angle_tol_deg, min_edge);
  const Eigen::Vector2d pivot = vertex_mean(polygon);

  PaperSearch search(polygon, formats, params);
  // Lines 4-19: initial hypotheses on every convex orthogonal corner.
  for (const auto& c : corners) {
    if (c.convex) search.seed_corner(c, pivot);
  }
  if (search.empty()) return sol;
  // Lines 21-39: breadth-first expansion.
  sol.cap_hit = search.expand_all(deadline);
  sol.clock_ran_out = sol.cap_hit && deadline.passed();
  search.fill_solution(&sol);
  return sol;
}

}  // namespace palletd::layout_detail
