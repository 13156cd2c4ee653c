// Per-box support: area inside the outline, seams along shared edges, no seam across the interior.
#include "layout_scoring.hpp"

#include <algorithm>
#include <cmath>

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
  const double m = params.seam_margin_m;
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

BoxSupport box_support(const Box2d& box, const PolygonWithHoles& component,
                       const SeamEvidence* seams, const LayoutParams& params) {
  LayoutFrame frame;
  frame.theta_rad = box.yaw_rad;
  frame.pivot = box.center;
  const PolygonWithHoles fp = frame.to_frame(component);
  const double m = params.seam_margin_m;
  const double hx = box.long_m / 2, hy = box.short_m / 2;
  SeamTable table;
  if (seams != nullptr && !seams->empty() && seams->strength > 0.0) {
    table = SeamTable(*seams, frame, Rect{-hx - 2 * m, -hy - 2 * m, hx + 2 * m, hy + 2 * m});
  }
  return box_support(box, frame, fp, table.empty() ? nullptr : &table, params);
}

}  // namespace palletd::layout_detail
