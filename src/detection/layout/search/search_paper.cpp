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

int sign_of(double v) { return v >= 0 ? 1 : -1; }

}  // namespace

PaperSolution search_paper(const PolygonWithHoles& polygon, const PolygonWithHoles& edges,
                           const std::vector<BoxFormat>& formats, const LayoutParams& params,
                           const Deadline& deadline) {
  PaperSolution sol;
  double min_short = 1e9;
  for (const auto& f : formats) min_short = std::min(min_short, f.short_m);
  const double min_edge = min_corner_edge_m(min_short);
  const std::vector<Corner> corners = orthogonal_corners(edges, params.corner_angle_tol_deg, min_edge);

  std::vector<LayoutFrame> frames;
  std::vector<PolygonWithHoles> frame_polys;
  Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
  for (const auto& p : polygon.outer) pivot += p;
  if (!polygon.outer.empty()) pivot /= static_cast<double>(polygon.outer.size());

  std::vector<PaperNode> nodes;
  std::deque<int> queue;
  int best = -1;
  auto area_of = [&](int frame, const Rect& r) {
    return clipped_area(frame_polys[static_cast<std::size_t>(frame)], r.x0, r.y0, r.x1, r.y1);
  };
  auto push = [&](const PaperNode& n) {
    nodes.push_back(n);
    const int k = static_cast<int>(nodes.size()) - 1;
    queue.push_back(k);
    if (best < 0 || n.score > nodes[static_cast<std::size_t>(best)].score) best = k;
  };

  // Lines 4-19: initial hypotheses on every convex orthogonal corner.
  for (const auto& c : corners) {
    if (!c.convex) continue;
    LayoutFrame frame;
    frame.theta_rad = std::atan2(c.v.y() - c.prev.y(), c.v.x() - c.prev.x());
    frame.pivot = pivot;
    frames.push_back(frame);
    frame_polys.push_back(frame.to_frame(polygon));
    const int fi = static_cast<int>(frames.size()) - 1;
    const Eigen::Vector2d v = frame.to_frame(c.v);
    // e_p, e_n snapped to the frame axes.
    auto snap = [](Eigen::Vector2d d) {
      return std::abs(d.x()) >= std::abs(d.y()) ? Eigen::Vector2d(sign_of(d.x()), 0) : Eigen::Vector2d(0, sign_of(d.y()));
    };
    const Eigen::Vector2d ep = snap(frame.to_frame(c.prev) - v);
    const Eigen::Vector2d en = snap(frame.to_frame(c.next) - v);
    for (std::size_t f = 0; f < formats.size(); ++f) {
      for (bool on_prev : {true, false}) {
        const Eigen::Vector2d a = on_prev ? ep : en, b = on_prev ? en : ep;
        const double w = formats[f].long_m, h = formats[f].short_m;
        const Eigen::Vector2d far = v + a * w + b * h;
        PaperBox box;
        box.rect = {std::min(v.x(), far.x()), std::min(v.y(), far.y()), std::max(v.x(), far.x()),
                    std::max(v.y(), far.y())};
        box.format = static_cast<int>(f);
        box.long_along_x = std::abs(a.x()) > 0.5;
        box.ax = sign_of(far.x() - v.x());
        box.ay = sign_of(far.y() - v.y());
        const double inter = area_of(fi, box.rect);
        if (inter > params.a_min_fraction * w * h) push({box, -1, fi, inter});
      }
    }
  }
  if (nodes.empty()) return sol;

  // Lines 21-39: breadth-first expansion.
  std::vector<PaperBox> hyp, cand;
  std::size_t pops = 0;
  while (!queue.empty()) {
    if (nodes.size() >= params.paper_max_hypotheses || ((++pops & 63U) == 0 && deadline.passed())) {
      sol.cap_hit = true;
      break;
    }
    const int k = queue.front();
    queue.pop_front();
    const PaperNode cur = nodes[static_cast<std::size_t>(k)];
    hyp.clear();
    for (int n = k; n >= 0; n = nodes[static_cast<std::size_t>(n)].parent) hyp.push_back(nodes[static_cast<std::size_t>(n)].box);
    cand.clear();
    for (const auto& in : hyp) {  // FindStackedBoxes for every box and format
      for (std::size_t f = 0; f < formats.size(); ++f) {
        for (int way = 0; way < 4; ++way) {
          const bool turned = (way & 1) != 0;
          const bool far_y = way < 2;
          // New box extents along the frame axes: aligned keeps B_in's long axis.
          const bool long_x = turned ? !in.long_along_x : in.long_along_x;
          const double lx = long_x ? formats[f].long_m : formats[f].short_m;
          const double ly = long_x ? formats[f].short_m : formats[f].long_m;
          PaperBox nb;
          nb.format = static_cast<int>(f);
          nb.long_along_x = long_x;
          nb.ax = in.ax;
          nb.ay = in.ay;
          const Rect& r = in.rect;
          if (far_y) {  // beyond the far y edge, flush with the pivot-side x edge
            nb.rect.x0 = in.ax > 0 ? r.x0 : r.x1 - lx;
            nb.rect.y0 = in.ay > 0 ? r.y1 : r.y0 - ly;
          } else {      // beyond the far x edge, flush with the pivot-side y edge
            nb.rect.x0 = in.ax > 0 ? r.x1 : r.x0 - lx;
            nb.rect.y0 = in.ay > 0 ? r.y0 : r.y1 - ly;
          }
          nb.rect.x1 = nb.rect.x0 + lx;
          nb.rect.y1 = nb.rect.y0 + ly;
          const double box_area = lx * ly;
          if (area_of(cur.frame, nb.rect) <= params.a_min_fraction * box_area) continue;  // eq. (2)
          double over = 0;  // eq. (3), Area(B_new ∩ ∪ B_j) bounded by the sum of pairwise overlaps
          for (const auto& b : hyp) over += overlap(nb.rect, b.rect);
          if (over >= params.a_max_fraction * box_area) continue;
          bool dup = false;
          for (const auto& c : cand) {
            if (std::abs(c.rect.x0 - nb.rect.x0) < 1e-9 && std::abs(c.rect.y0 - nb.rect.y0) < 1e-9 &&
                c.long_along_x == nb.long_along_x && c.format == nb.format) {
              dup = true;
              break;
            }
          }
          if (!dup) cand.push_back(nb);
        }
      }
    }
    for (const auto& nb : cand) {
      push({nb, k, cur.frame, cur.score + area_of(cur.frame, nb.rect)});
    }
  }
  sol.visited = nodes.size();
  const PaperNode& b = nodes[static_cast<std::size_t>(best)];
  sol.score = b.score;
  const LayoutFrame& frame = frames[static_cast<std::size_t>(b.frame)];
  for (int n = best; n >= 0; n = nodes[static_cast<std::size_t>(n)].parent) {
    const PaperBox& pb = nodes[static_cast<std::size_t>(n)].box;
    sol.boxes.push_back(frame.to_layer(FrameBox{pb.rect, pb.format, pb.long_along_x}, formats));
  }
  std::reverse(sol.boxes.begin(), sol.boxes.end());
  sol.found = !sol.boxes.empty();
  return sol;
}

}  // namespace palletd::layout_detail
