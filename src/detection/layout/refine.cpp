// refine_layout(): each box edge on the outline moves to the measured layer border, each edge
// shared with a neighbour to the seam line; box centres are the least-squares fit of these
// edge estimates with nominal sizes (sizes change only within the tolerance when both opposite
// edges are measured on the outline).
#include <algorithm>
#include <cmath>

#include "layout_internal.hpp"
#include "layout_scoring.hpp"

namespace palletd {

using namespace layout_detail;

namespace {

/// Layer points binned in a coarse grid so that each box only visits its neighbourhood.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector2f>& pts, double cell) : pts_(pts), cell_(cell) {
    if (pts.empty()) return;
    x0_ = y0_ = 1e300;
    double x1 = -1e300, y1 = -1e300;
    for (const auto& p : pts) {
      x0_ = std::min(x0_, static_cast<double>(p.x())); x1 = std::max(x1, static_cast<double>(p.x()));
      y0_ = std::min(y0_, static_cast<double>(p.y())); y1 = std::max(y1, static_cast<double>(p.y()));
    }
    w_ = static_cast<int>((x1 - x0_) / cell_) + 1;
    h_ = static_cast<int>((y1 - y0_) / cell_) + 1;
    bins_.assign(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_), {});
    for (std::size_t i = 0; i < pts.size(); ++i) bins_[bin(pts[i].x(), pts[i].y())].push_back(static_cast<std::uint32_t>(i));
  }
  template <typename F>
  void visit(double x0, double y0, double x1, double y1, F&& f) const {
    if (bins_.empty()) return;
    const int c0 = std::clamp(static_cast<int>((x0 - x0_) / cell_), 0, w_ - 1);
    const int c1 = std::clamp(static_cast<int>((x1 - x0_) / cell_), 0, w_ - 1);
    const int r0 = std::clamp(static_cast<int>((y0 - y0_) / cell_), 0, h_ - 1);
    const int r1 = std::clamp(static_cast<int>((y1 - y0_) / cell_), 0, h_ - 1);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        for (auto i : bins_[static_cast<std::size_t>(r) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(c)]) f(pts_[i]);
      }
    }
  }

 private:
  std::size_t bin(double x, double y) const {
    const int c = std::clamp(static_cast<int>((x - x0_) / cell_), 0, w_ - 1);
    const int r = std::clamp(static_cast<int>((y - y0_) / cell_), 0, h_ - 1);
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(c);
  }
  const std::vector<Eigen::Vector2f>& pts_;
  double cell_;
  double x0_ = 0, y0_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<std::vector<std::uint32_t>> bins_;
};

}  // namespace

LayoutResult refine_layout(const LayoutResult& found, const LayerResult& layer,
                           const std::vector<BoxFormat>& formats, const SeamEvidence* seams,
                           const LayoutParams& params) {
  (void)formats;
  LayoutResult out = found;
  if (found.status != DetectionStatus::ok || found.boxes.empty()) return out;
  double layer_area = 0;
  for (const auto& p : layer.polygons) layer_area += area(p);
  const double pitch = layer.points_2d.empty() ? 0.003
                       : std::sqrt(layer_area / static_cast<double>(layer.points_2d.size()));
  const PointGrid grid(layer.points_2d, 0.05);
  const double m = params.seam_margin_m;
  const double band = std::max(0.02, 4 * pitch);
  const bool use_seams = seams != nullptr && !seams->empty() && seams->strength > 0;

  // One layout frame and seam table per component (its boxes are turned by 0 or 90 deg).
  struct ComponentFrame {
    bool built = false;
    LayoutFrame frame;
    PolygonWithHoles polygon;  ///< in the frame
    SeamTable table;
  };
  std::vector<ComponentFrame> frames(layer.polygons.size());
  auto frame_of = [&](std::size_t ci, const Box2d& box) -> ComponentFrame& {
    ComponentFrame& cf = frames[ci];
    if (cf.built) return cf;
    cf.built = true;
    double theta = std::fmod(box.yaw_rad, M_PI / 2);
    if (theta < 0) theta += M_PI / 2;
    cf.frame.theta_rad = theta;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& v : layer.polygons[ci].outer) c += v;
    if (!layer.polygons[ci].outer.empty()) c /= static_cast<double>(layer.polygons[ci].outer.size());
    cf.frame.pivot = c;
    cf.polygon = cf.frame.to_frame(layer.polygons[ci]);
    if (use_seams) {
      Rect b{1e300, 1e300, -1e300, -1e300};
      for (const auto& v : cf.polygon.outer) {
        b.x0 = std::min(b.x0, v.x()); b.x1 = std::max(b.x1, v.x());
        b.y0 = std::min(b.y0, v.y()); b.y1 = std::max(b.y1, v.y());
      }
      cf.table = SeamTable(*seams, cf.frame, Rect{b.x0 - 2 * m, b.y0 - 2 * m, b.x1 + 2 * m, b.y1 + 2 * m});
    }
    return cf;
  };

  for (std::size_t bi = 0; bi < out.boxes.size(); ++bi) {
    Box2d& box = out.boxes[bi];
    const auto ci = static_cast<std::size_t>(found.box_component[bi]);
    if (ci >= layer.polygons.size()) continue;
    LayoutFrame frame;
    frame.theta_rad = box.yaw_rad;
    frame.pivot = box.center;
    const PolygonWithHoles fp = frame.to_frame(layer.polygons[ci]);
    const double hx = box.long_m / 2, hy = box.short_m / 2;
    ComponentFrame& cf = frame_of(ci, box);
    BoxView view;
    view.table = &cf.table;
    view.center = cf.frame.to_frame(box.center);
    view.turned = std::abs(std::remainder(box.yaw_rad - cf.frame.theta_rad, M_PI)) > M_PI / 4;
    // Collect the layer points near the box, in the box frame.
    std::vector<Eigen::Vector2d> local;
    const double reach = std::hypot(hx, hy) + band;
    const double cs = std::cos(frame.theta_rad), sn = std::sin(frame.theta_rad);
    grid.visit(box.center.x() - reach, box.center.y() - reach, box.center.x() + reach, box.center.y() + reach,
               [&](const Eigen::Vector2f& p) {
                 const double dx = p.x() - box.center.x(), dy = p.y() - box.center.y();
                 const Eigen::Vector2d q(cs * dx + sn * dy, -sn * dx + cs * dy);  // frame.to_frame(p)
                 if (std::abs(q.x()) <= hx + band && std::abs(q.y()) <= hy + band) local.push_back(q);
               });
    // Edge estimates per axis: (position, outward sign, weight, outline?).
    double est[2][2] = {{0, 0}, {0, 0}};  // [axis][side]: measured edge position
    bool have[2][2] = {{false, false}, {false, false}}, outline[2][2] = {{false, false}, {false, false}};
    double weight[2][2] = {{0, 0}, {0, 0}};
    for (int axis = 0; axis < 2; ++axis) {
      const double half = axis == 0 ? hx : hy, other = axis == 0 ? hy : hx;
      for (int side = 0; side < 2; ++side) {
        const double out_sign = side == 0 ? -1.0 : 1.0;
        const double pos = out_sign * half;
        const double lo = -other + m, hi = other - m;
        if (hi <= lo) continue;
        const double a0 = pos + out_sign * m, a1 = pos + out_sign * 3 * m;
        Rect outside = axis == 0 ? Rect{std::min(a0, a1), lo, std::max(a0, a1), hi}
                                 : Rect{lo, std::min(a0, a1), hi, std::max(a0, a1)};
        const bool neighbour = clipped_area(fp, outside.x0, outside.y0, outside.x1, outside.y1) > 0.5 * outside.area();
        if (!neighbour) {
          // Outline edge: per slice along the edge, the outermost layer point; median + half a pixel.
          const int slices = std::max(1, static_cast<int>((hi - lo) / std::max(pitch, 0.002)));
          std::vector<double> extreme(static_cast<std::size_t>(slices), -1e300);
          for (const auto& q : local) {
            const double along = axis == 0 ? q.y() : q.x();
            const double across = (axis == 0 ? q.x() : q.y()) * out_sign;
            if (along < lo || along >= hi || std::abs(across - half) > band) continue;
            const auto s = static_cast<std::size_t>(std::min(slices - 1, static_cast<int>((along - lo) / (hi - lo) * slices)));
            extreme[s] = std::max(extreme[s], across);
          }
          std::vector<double> vals;
          for (double e : extreme) if (e > -1e299) vals.push_back(e);
          if (vals.size() >= 3) {
            std::nth_element(vals.begin(), vals.begin() + static_cast<long>(vals.size() / 2), vals.end());
            est[axis][side] = out_sign * (vals[vals.size() / 2] + 0.5 * pitch);
            have[axis][side] = outline[axis][side] = true;
            weight[axis][side] = 1.0;
          }
        } else if (!cf.table.empty()) {
          // Shared edge: centroid of the seam profile across the edge.
          // Search twice the margin (the nominal grid can be off by the gaps between boxes),
          // then take the centroid around the strongest line only.
          double sw = 0, s = 0;
          const double cell = seams->cell_m;
          std::vector<std::pair<double, double>> profile;  // (position, mean seam along the edge)
          for (double off = -2 * m; off <= 2 * m; off += cell) {
            const double p = pos + off;
            const Rect strip = axis == 0 ? Rect{p - cell / 2, lo, p + cell / 2, hi} : Rect{lo, p - cell / 2, hi, p + cell / 2};
            profile.emplace_back(p, view.mean(strip));
          }
          double peak_p = pos, peak_v = 0.0;
          for (const auto& [p, v] : profile) {
            if (v > peak_v || (v == peak_v && std::abs(p - pos) < std::abs(peak_p - pos))) {
              peak_v = v;
              peak_p = p;
            }
          }
          for (const auto& [p, v] : profile) {
            if (v > 0.2 && std::abs(p - peak_p) <= 0.5 * m) {
              s += v * p;
              sw += v;
            }
          }
          if (sw > 0.5) {
            est[axis][side] = s / sw;
            have[axis][side] = true;
            weight[axis][side] = 0.5;
          }
        }
      }
    }
    double shift[2] = {0, 0};
    double size[2] = {box.long_m, box.short_m};
    for (int axis = 0; axis < 2; ++axis) {
      const double half = axis == 0 ? hx : hy;
      if (outline[axis][0] && outline[axis][1]) {
        const double measured = est[axis][1] - est[axis][0];
        size[axis] = std::clamp(measured, 2 * half - params.refine_size_tolerance_m, 2 * half + params.refine_size_tolerance_m);
      }
      double sw = 0, s = 0;
      for (int side = 0; side < 2; ++side) {
        if (!have[axis][side]) continue;
        const double c = est[axis][side] - (side == 0 ? -1.0 : 1.0) * size[axis] / 2;
        s += weight[axis][side] * c;
        sw += weight[axis][side];
      }
      if (sw > 0) shift[axis] = s / sw;
      if (std::abs(shift[axis]) > 0.25 * box.short_m) shift[axis] = 0;  // a wrong association
    }
    box.center = frame.to_layer(Eigen::Vector2d(shift[0], shift[1]));
    box.long_m = size[0];
    box.short_m = size[1];
  }
  // Scores and coverage of the refined boxes.
  double covered = 0;
  for (std::size_t bi = 0; bi < out.boxes.size(); ++bi) {
    const auto ci = static_cast<std::size_t>(found.box_component[bi]);
    if (ci >= layer.polygons.size()) continue;
    ComponentFrame& cf = frame_of(ci, out.boxes[bi]);
    const BoxSupport s = box_support(out.boxes[bi], cf.frame, cf.polygon, cf.table.empty() ? nullptr : &cf.table, params);
    out.box_scores[bi] = s.score;
    covered += s.inside_area_m2;
  }
  if (layer_area > 0) out.coverage = std::min(1.0, covered / layer_area);
  return out;
}

LayoutResult solve_layout(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                          const std::vector<BoxFormat>& formats, const LayoutParams& params) {
  if (layer.status != DetectionStatus::ok) {
    LayoutResult r;
    r.status = layer.status;
    r.reason = layer.reason;
    return r;
  }
  const SeamEvidence seams = build_seam_evidence(frame, cloud, layer);
  const LayoutResult found = find_layout(layer.polygons, formats, params, &seams);
  if (!params.refine || params.search == SearchMode::paper) return found;
  return refine_layout(found, layer, formats, &seams, params);
}

}  // namespace palletd
