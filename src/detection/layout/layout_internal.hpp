// Private to the layout stage: the layout frame, candidate lines, area tables, searches.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "palletd/detection/layout.hpp"

namespace palletd::layout_detail {

/// Rectangle in the layout frame [m] (axis-aligned).
struct Rect {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  [[nodiscard]] double area() const { return (x1 - x0) * (y1 - y0); }
};
double overlap(const Rect& a, const Rect& b);
/// Bounding rectangle of a polygon's outer ring (x0 > x1 when the ring is empty).
Rect bounds_of(const PolygonWithHoles& polygon);
/// Length of the outer ring and the holes [m].
double rings_length_m(const PolygonWithHoles& polygon);

/// The smallest box area, the shortest box side and the shortest long side of a recipe's formats.
struct FormatExtremes {
  double min_area_m2 = 0.0;
  double min_short_m = 0.0;
  double min_long_m = 0.0;
};
FormatExtremes format_extremes(const std::vector<BoxFormat>& formats);

/// A recipe's formats with those of one carton size merged (same_carton(): a camera that looks
/// at the tops sees the same carton), so the search lays out the first of them. `original[i]`:
/// the recipe index of formats[i].
struct DistinctFormats {
  std::vector<BoxFormat> formats;
  std::vector<int> original;
};
DistinctFormats distinct_formats(const std::vector<BoxFormat>& formats);

/// Candidate lines closer than this merge, and a seam may lie this far from a box side [m]:
/// LayoutParams::line_merge_tol_m, or (0 = auto) 6 % of the shortest box side within 6-20 mm.
double line_merge_tol_m(const LayoutParams& params, double min_short_m);

/// Outline edges shorter than this carry no orthogonal corner [m]: a quarter of the shortest box
/// side, at least 20 mm.
double min_corner_edge_m(double min_short_m);

/// Outline scores closer than this tie [m^2]: the ambiguity margin's share of the smallest box,
/// plus a strip as wide as the outline's tolerance along the shortest box side (what an outline
/// off by that much at one box end changes; LayoutParams::outline_tolerance_m).
double tie_margin_m2(const LayoutParams& params, const std::vector<BoxFormat>& formats);

/// A box placed in the layout frame.
struct FrameBox {
  Rect rect;
  int format = 0;
  bool long_along_x = true;
};

/// The frame in which a component's layout is axis-aligned: p_frame = R(-theta) (p_layer - pivot).
struct LayoutFrame {
  /// The map from layer into frame coordinates with the turn's cosine and sine computed once: for
  /// loops over many points (to_frame(p) is this map built for one point).
  struct ToFrame {
    double cos_theta = 1.0, sin_theta = 0.0;
    Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
    [[nodiscard]] Eigen::Vector2d operator()(const Eigen::Vector2d& p) const {
      const Eigen::Vector2d d = p - pivot;
      return {cos_theta * d.x() + sin_theta * d.y(), -sin_theta * d.x() + cos_theta * d.y()};
    }
  };

  double theta_rad = 0.0;  ///< orientation of the layout mod 90 deg, in [0, pi/2)
  Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
  [[nodiscard]] ToFrame to_frame_map() const;
  [[nodiscard]] Eigen::Vector2d to_frame(const Eigen::Vector2d& p) const;
  [[nodiscard]] Eigen::Vector2d to_layer(const Eigen::Vector2d& q) const;
  [[nodiscard]] PolygonWithHoles to_frame(const PolygonWithHoles& polygon) const;
  [[nodiscard]] Box2d to_layer(const FrameBox& box, const std::vector<BoxFormat>& formats) const;
};

/// An orthogonal (convex or concave) corner of a ring.
struct Corner {
  Eigen::Vector2d v, prev, next;  ///< vertex and its neighbours
  bool convex = true;
};
std::vector<Corner> orthogonal_corners(const PolygonWithHoles& polygon, double angle_tol_deg,
                                       double min_edge_m);

/// Layout orientations mod 90 deg of a component, best supported first (length-weighted edges
/// near the orientations of its orthogonal corners). Empty when there is no orthogonal corner.
std::vector<double> layout_orientations(const PolygonWithHoles& polygon, double angle_tol_deg,
                                        double min_edge_m);

/// Seam evidence turned into a layout frame, line-filtered, as a summed-area table.
class SeamTable {
 public:
  SeamTable() = default;
  SeamTable(const SeamEvidence& seams, const LayoutFrame& frame, const Rect& bounds);
  [[nodiscard]] bool empty() const { return w_ == 0; }
  /// Seam mass [m^2] (sum of seam values times cell area) inside a rectangle.
  [[nodiscard]] double mass(const Rect& r) const;
  /// Mean seam value along a thin strip.
  [[nodiscard]] double mean(const Rect& r) const;
  /// Mean seam value along a thin strip, seams widened by the search margin (edge support).
  [[nodiscard]] double support(const Rect& r) const;
  [[nodiscard]] double cell() const { return cell_; }

 private:
  double sum_cells(const std::vector<double>& sat, const Rect& r, double* cells) const;
  double x0_ = 0, y0_ = 0, cell_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<double> sat_;          ///< (h+1) x (w+1), line-filtered seams
  std::vector<double> sat_support_;  ///< the same, dilated across lines
};

/// A box-centred view of a layout frame's seam table: local x along the box's long side.
/// Boxes of a layout are turned by 0 or 90 deg against the frame, so local rectangles stay
/// axis-aligned rectangles of the frame.
struct BoxView {
  const SeamTable* table = nullptr;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< box centre in the frame
  bool turned = false;  ///< local x = frame -y, local y = frame x
  [[nodiscard]] Rect map(const Rect& r) const {
    if (!turned) return {center.x() + r.x0, center.y() + r.y0, center.x() + r.x1, center.y() + r.y1};
    return {center.x() + r.y0, center.y() - r.x1, center.x() + r.y1, center.y() - r.x0};
  }
  [[nodiscard]] double mean(const Rect& r) const { return table->mean(map(r)); }
  [[nodiscard]] double support(const Rect& r) const { return table->support(map(r)); }
  [[nodiscard]] double cell() const { return table->cell(); }
};

/// How the edges of a box that have layer beyond them (neighbours) lie on seams.
struct EdgeEvidence {
  double neighbour_len = 0.0;  ///< length of edge with layer beyond it [m]
  double supported_len = 0.0;  ///< of which on a seam (weighted by seam value) [m]
};

/// One side of a box rectangle, as the walks along box sides see it.
struct BoxSide {
  bool vertical = true;  ///< a side at constant x (left or right)
  double pos = 0.0;      ///< line of the side [m]
  double out = 1.0;      ///< -1 or +1: the direction across the side away from the box
  double lo = 0.0, hi = 0.0;  ///< extent along the side, shrunk by the margin at both ends [m]
  double beyond0 = 0.0, beyond1 = 0.0;  ///< strip across the side beyond the box: margin to 3 margins out [m]
  /// The rectangle spanning [s0, s1] along the side and [a0, a1] across it.
  [[nodiscard]] Rect span(double s0, double s1, double a0, double a1) const {
    return vertical ? Rect{a0, s0, a1, s1} : Rect{s0, a0, s1, a1};
  }
  /// The strip beyond the side along [s0, s1] (where a neighbour would lie).
  [[nodiscard]] Rect beyond(double s0, double s1) const { return span(s0, s1, beyond0, beyond1); }
  /// A line `width_m` wide centred on the side along [s0, s1].
  [[nodiscard]] Rect line(double s0, double s1, double width_m) const {
    return span(s0, s1, pos - width_m / 2, pos + width_m / 2);
  }
};

/// Calls fn(BoxSide) for the four sides of `r` (left, right, bottom, top), skipping sides not
/// longer than twice the margin.
template <typename Fn>
void for_each_box_side(const Rect& r, double margin_m, Fn&& fn) {
  for (int e = 0; e < 4; ++e) {
    BoxSide side;
    side.vertical = e < 2;
    side.pos = e == 0 ? r.x0 : e == 1 ? r.x1 : e == 2 ? r.y0 : r.y1;
    side.out = (e == 0 || e == 2) ? -1.0 : 1.0;
    side.lo = (side.vertical ? r.y0 : r.x0) + margin_m;
    side.hi = (side.vertical ? r.y1 : r.x1) - margin_m;
    if (side.hi <= side.lo) continue;
    const double a = side.pos + side.out * margin_m, b = side.pos + side.out * 3 * margin_m;
    side.beyond0 = std::min(a, b);
    side.beyond1 = std::max(a, b);
    fn(static_cast<const BoxSide&>(side));
  }
}

/// Walks the four edges of `r` in segments; `layer_area(rect)` gives the layer area of a rect.
template <typename Table, typename AreaFn>
EdgeEvidence edge_evidence(const Rect& r, const Table& table, AreaFn&& layer_area, double margin_m) {
  EdgeEvidence ev;
  const double seg = 0.04;
  for_each_box_side(r, margin_m, [&](const BoxSide& side) {
    const int n = std::max(1, static_cast<int>(std::lround((side.hi - side.lo) / seg)));
    const double step = (side.hi - side.lo) / n;
    for (int k = 0; k < n; ++k) {
      const double s0 = side.lo + k * step, s1 = s0 + step;
      const Rect beyond = side.beyond(s0, s1);
      if (layer_area(beyond) < 0.5 * beyond.area()) continue;
      ev.neighbour_len += step;
      ev.supported_len += step * std::min(1.0, 2.0 * table.support(side.line(s0, s1, table.cell())));  // half a seam counts
    }
  });
  return ev;
}

/// Area(rect ∩ polygon) by the chosen method, in the layout frame. With dilate_m > 0 (raster
/// only), the area of rect ∩ the polygon grown by a square of half-width dilate_m: the polygon
/// plus everything within dilate_m of it along the layout axes.
class AreaOracle {
 public:
  AreaOracle(const PolygonWithHoles& frame_polygon, AreaMethod method, double raster_cell_m, double dilate_m = 0.0);
  [[nodiscard]] double area(const Rect& r) const;

 private:
  const PolygonWithHoles* polygon_;
  AreaMethod method_;
  double dilate_m_ = 0.0;
  double x0_ = 0, y0_ = 0, cell_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<double> sat_;
};

struct Deadline {
  std::chrono::steady_clock::time_point end;
  [[nodiscard]] bool passed() const { return std::chrono::steady_clock::now() >= end; }
};

/// Budget of one best-first search: node expansions (the primary, deterministic budget: the same
/// input gives the same result whatever the machine load) and a wall-clock deadline (a safety
/// cap only). Either running out ends the search with budget_exhausted.
struct SearchBudget {
  std::size_t expansions = 0;
  Deadline deadline;
};

/// Near-equal, materially different layouts kept per search (more: the seams choose by a
/// seam-penalised search constrained to the outline's near-equal layouts).
constexpr std::size_t kMaxAlternatives = 6;

/// One component's answer in its layout frame.
struct ComponentSolution {
  bool found = false;
  std::vector<FrameBox> boxes;
  double score = 0.0;       ///< [m^2]
  double outline_score = 0.0;  ///< covered area of the chosen layout, without seam penalties [m^2]
  bool has_runner_up = false;
  std::vector<FrameBox> runner_up;
  double runner_up_score = 0.0;
  /// Materially different layouts within the ambiguity margin of the best, best first
  /// (the runner-up is the first of them).
  std::vector<std::vector<FrameBox>> alternatives;
  std::vector<double> alternative_scores;
  bool budget_exhausted = false;
  bool clock_ran_out = false;  ///< the wall-clock cap, not the expansion count, ended it
  std::size_t visited = 0;
  std::size_t expansions = 0;  ///< node expansions used (queue pops)
  std::string reason;       ///< when !found
};

/// Rings simplified (Douglas-Peucker, tolerance_m) so that densely sampled or jagged outlines
/// still show their long straight edges; used for corners, orientations and candidate lines.
PolygonWithHoles simplified(const PolygonWithHoles& polygon, double tolerance_m);

/// Which outline edges (a -> b, frame coordinates, `out` the unit normal away from the layer)
/// seed candidate lines; empty = all of them.
using SeedEdgeFilter = std::function<bool(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& out)>;

/// best-first search in one layout frame. `frame_edges` (the simplified outline, same frame) gives
/// the candidate lines; `frame_polygon` the exact areas. With `seams`, the score subtracts seam
/// penalties; layouts covering less than `min_outline_score` [m^2] are pruned (so that seams
/// only choose among layouts the outline supports). With `memory`, the search's node pool and
/// queues live there and keep their capacity for the next search.
ComponentSolution search_best_first(const PolygonWithHoles& frame_polygon,
                                    const PolygonWithHoles& frame_edges,
                                    const std::vector<BoxFormat>& formats, const LayoutParams& params,
                                    const SeamTable* seams, const SearchBudget& budget,
                                    double min_outline_score = -1e300, const SeedEdgeFilter& seed_ok = {},
                                    SearchMemory* memory = nullptr);

/// Algorithms 1-3 in the layer frame (no layout frame; the paper's boxes carry their own angle).
struct PaperSolution {
  bool found = false;
  std::vector<Box2d> boxes;
  double score = 0.0;
  bool cap_hit = false;
  bool clock_ran_out = false;  ///< the deadline, not the hypothesis cap, ended it
  std::size_t visited = 0;
};
PaperSolution search_paper(const PolygonWithHoles& polygon, const PolygonWithHoles& edges,
                           const std::vector<BoxFormat>& formats, const LayoutParams& params,
                           const Deadline& deadline);

/// complete_unseen's answer: the boxes given plus those completed across edges where the depth
/// ends; `tied` when another placement of a completed box explains the view as well.
struct UnseenCompletion {
  std::vector<FrameBox> boxes;
  std::size_t added = 0;
  bool tied = false;
  /// Uncovered layer next to where the depth ends that no box could be completed over (too
  /// little of it seen): the layout there is not determined by the view.
  bool open = false;
  /// Node expansions of a search again with candidate lines from seen edges only (its layout,
  /// when better explained, replaces the one given in `boxes`; the last `added` completed).
  std::size_t expansions = 0;
  /// The deadline passed before every completion was tried: `boxes` holds the best one found
  /// by then, and another may explain the layer better.
  bool timed_out = false;
};

/// Completes one component's layout (layout frame) with boxes the outline cuts where the depth
/// ends (LayoutParams::unseen_min_fraction, complete_unseen.cpp), until `deadline`. With
/// `research`, when part of the outline is unseen and the completed layout leaves the layer less
/// than explained, the component is searched again (within that budget) with candidate lines
/// from seen edges only.
UnseenCompletion complete_unseen(const std::vector<FrameBox>& boxes, const PolygonWithHoles& frame_polygon,
                                 const PolygonWithHoles& frame_edges, const LayoutFrame& frame,
                                 const std::vector<BoxFormat>& formats, const LayerSurroundings& around,
                                 const LayoutParams& params, const Deadline& deadline,
                                 const SearchBudget* research = nullptr);

/// Two frame layouts are the same when every box has a twin (same orientation, centres closer
/// than tol_m).
bool same_layout(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b, double tol_m);

}  // namespace palletd::layout_detail
