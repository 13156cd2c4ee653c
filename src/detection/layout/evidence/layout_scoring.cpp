// Per-box support: area inside the outline, seams along shared edges, no seam across the interior.
#include "evidence/layout_scoring.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "layer_raster.hpp"
#include "layout_internal.hpp"

namespace palletd::layout_detail {

BoxSupport box_support(const Box2d& box, const LayoutFrame& frame, const PolygonWithHoles& frame_polygon,
                       const SeamTable* table, const LayoutParams& params) {
  BoxSupport s;
  const double hx = box.long_m / 2, hy = box.short_m / 2;
  const double box_area = box.long_m * box.short_m;
  BoxView view;
  view.table = table;
  view.center = frame.to_frame(box.center);
  const double d = std::remainder(box.yaw_rad - frame.theta_rad, M_PI);
  view.turned = std::abs(d) > M_PI / 4;
  auto layer_area = [&](const Rect& local) {
    const Rect r = view.map(local);
    return clipped_area(frame_polygon, r.x0, r.y0, r.x1, r.y1);
  };
  s.inside_area_m2 = layer_area({-hx, -hy, hx, hy});
  s.inside_fraction = box_area > 0 ? std::clamp(s.inside_area_m2 / box_area, 0.0, 1.0) : 0.0;
  s.score = s.inside_fraction;
  if (table == nullptr || table->empty()) return s;
  const double m = params.seams.margin_m;
  const double cell = table->cell();
  // Interior: the strongest row or column of seam inside the shrunk box.
  double crossing = 0;
  for (double y = -hy + m; y + cell <= hy - m; y += cell) {
    crossing = std::max(crossing, view.mean({-hx + m, y, hx - m, y + cell}));
  }
  for (double x = -hx + m; x + cell <= hx - m; x += cell) {
    crossing = std::max(crossing, view.mean({x, -hy + m, x + cell, hy - m}));
  }
  s.interior_seam = std::clamp(crossing, 0.0, 1.0);
  // Edges with a neighbour across them (layer on both sides) should lie on a seam line.
  const EdgeEvidence ev = edge_evidence(Rect{-hx, -hy, hx, hy}, view, layer_area, m);
  s.shared_edges = ev.neighbour_len > 0 ? 1 : 0;
  if (ev.neighbour_len > 0) s.edge_seam = ev.supported_len / ev.neighbour_len;
  s.score = s.inside_fraction * (1.0 - s.interior_seam) * (0.5 + 0.5 * s.edge_seam);
  return s;
}

namespace {

/// The layout frame of the box itself (its centre, turned with it).
LayoutFrame frame_of(const Box2d& box) {
  LayoutFrame frame;
  frame.theta_rad = box.yaw_rad;
  frame.pivot = box.center;
  return frame;
}

/// The seam table over the box in its own frame, out to two margins beyond it (empty without
/// seams).
SeamTable table_around(const Box2d& box, const LayoutFrame& frame, const SeamEvidence* seams,
                       const LayoutParams& params) {
  if (seams == nullptr || seams->empty() || !(seams->strength > 0.0)) return {};
  const double m = params.seams.margin_m;
  const double hx = box.long_m / 2, hy = box.short_m / 2;
  return SeamTable(*seams, frame, Rect{-hx - 2 * m, -hy - 2 * m, hx + 2 * m, hy + 2 * m});
}

}  // namespace

BoxSupport box_support(const Box2d& box, const PolygonWithHoles& component, const SeamEvidence* seams,
                       const LayoutParams& params) {
  const LayoutFrame frame = frame_of(box);
  const SeamTable table = table_around(box, frame, seams, params);
  return box_support(box, frame, frame.to_frame(component), table.empty() ? nullptr : &table, params);
}

double seam_across_middle(const Box2d& box, const SeamEvidence* seams, const LayoutParams& params,
                          double reach_m) {
  const LayoutFrame frame = frame_of(box);
  const SeamTable table = table_around(box, frame, seams, params);
  if (table.empty()) return 0.0;
  const double m = params.seams.margin_m;
  const double hy = box.short_m / 2;
  BoxView view;
  view.table = &table;
  view.center = frame.to_frame(box.center);
  const double cell = table.cell();
  double strongest = 0.0;
  for (double x = -reach_m; x + cell <= reach_m + 1e-9; x += cell)
    strongest = std::max(strongest, view.mean({x, -hy + m, x + cell, hy - m}));
  return std::clamp(strongest, 0.0, 1.0);
}

double largest_uncovered_m2(const PolygonWithHoles& frame_polygon, const std::vector<FrameBox>& boxes, double gap_m) {
  const Rect b = bounds_of(frame_polygon);
  const double cell = 0.005;
  const int w = static_cast<int>(std::ceil((b.x1 - b.x0) / cell)) + 2, h = static_cast<int>(std::ceil((b.y1 - b.y0) / cell)) + 2;
  if (!(b.x1 > b.x0) || w <= 0 || h <= 0 || static_cast<double>(w) * h > 4e6) return 0.0;
  auto to_px = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x() - b.x0) / cell * 16.0)) + 16,
                     static_cast<int>(std::lround((p.y() - b.y0) / cell * 16.0)) + 16);
  };
  auto ring_pts = [&](const Ring2d& ring) {
    std::vector<cv::Point> pts;
    for (const auto& p : ring) pts.push_back(to_px(p));
    return pts;
  };
  // The layer less its boxes, drawn straight into the cells (the Mat is a view of them).
  std::vector<std::uint8_t> cells(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0);
  cv::Mat mask(h, w, CV_8U, cells.data());
  std::vector<std::vector<cv::Point>> outer{ring_pts(frame_polygon.outer)};
  cv::fillPoly(mask, outer, cv::Scalar(1), cv::LINE_8, 4);
  std::vector<std::vector<cv::Point>> holes;
  for (const auto& hole : frame_polygon.holes) holes.push_back(ring_pts(hole));
  if (!holes.empty()) cv::fillPoly(mask, holes, cv::Scalar(0), cv::LINE_8, 4);
  for (const auto& box : boxes) {
    const cv::Point a = to_px({box.rect.x0, box.rect.y0}), c = to_px({box.rect.x1, box.rect.y1});
    cv::rectangle(mask, cv::Rect(cv::Point(a.x / 16, a.y / 16), cv::Point(c.x / 16, c.y / 16)), cv::Scalar(0), cv::FILLED);
  }
  // Gaps between boxes and slivers along the outline are narrower than gap_m: opened away.
  const int k = std::max(1, static_cast<int>(std::lround(gap_m / cell)));
  open_square(cells, w, h, k);
  return static_cast<double>(largest_piece_cells(cells, w, h)) * cell * cell;
}

}  // namespace palletd::layout_detail
