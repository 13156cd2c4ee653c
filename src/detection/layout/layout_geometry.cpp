// Layout frame, orthogonal corners, orientations, exact rectangle clipping, area and seam tables.
#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/detection/look_alike_formats.hpp"

#include "evidence/seam_raster.hpp"
#include "layer_raster.hpp"
#include "layout_internal.hpp"

namespace palletd {

namespace {

/// Sutherland-Hodgman of one ring against x >= / <= / y >= / y <= limit; exact for any simple ring
/// against a convex window (degenerate edges along the window carry no area).
template <typename Inside, typename Cut>
void clip_half(const std::vector<Eigen::Vector2d>& in, std::vector<Eigen::Vector2d>& out,
               Inside inside, Cut cut) {
  out.clear();
  const std::size_t n = in.size();
  if (n == 0) return;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& a = in[(i + n - 1) % n];
    const Eigen::Vector2d& b = in[i];
    const bool ia = inside(a), ib = inside(b);
    if (ib) {
      if (!ia) out.push_back(cut(a, b));
      out.push_back(b);
    } else if (ia) {
      out.push_back(cut(a, b));
    }
  }
}

double clipped_ring_area(const Ring2d& ring, double x0, double y0, double x1, double y1) {
  // Fast paths: ring bounding box inside or outside the window.
  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const auto& p : ring) {
    bx0 = std::min(bx0, p.x()); bx1 = std::max(bx1, p.x());
    by0 = std::min(by0, p.y()); by1 = std::max(by1, p.y());
  }
  if (bx1 <= x0 || bx0 >= x1 || by1 <= y0 || by0 >= y1) return 0.0;
  if (bx0 >= x0 && bx1 <= x1 && by0 >= y0 && by1 <= y1) return std::abs(signed_area(ring));
  std::vector<Eigen::Vector2d> a(ring.begin(), ring.end()), b;
  auto cut_x = [](double x) {
    return [x](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
      const double t = (x - p.x()) / (q.x() - p.x());
      return Eigen::Vector2d(x, p.y() + t * (q.y() - p.y()));
    };
  };
  auto cut_y = [](double y) {
    return [y](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
      const double t = (y - p.y()) / (q.y() - p.y());
      return Eigen::Vector2d(p.x() + t * (q.x() - p.x()), y);
    };
  };
  clip_half(a, b, [x0](const Eigen::Vector2d& p) { return p.x() >= x0; }, cut_x(x0));
  clip_half(b, a, [x1](const Eigen::Vector2d& p) { return p.x() <= x1; }, cut_x(x1));
  clip_half(a, b, [y0](const Eigen::Vector2d& p) { return p.y() >= y0; }, cut_y(y0));
  clip_half(b, a, [y1](const Eigen::Vector2d& p) { return p.y() <= y1; }, cut_y(y1));
  return std::abs(signed_area(a));
}

double wrap_quarter(double a) {  // into [0, pi/2)
  const double q = M_PI / 2.0;
  a = std::fmod(a, q);
  if (a < 0) a += q;
  if (a >= q) a -= q;
  return a;
}

double quarter_diff(double a, double b) {  // signed difference mod pi/2 in [-pi/4, pi/4)
  double d = std::fmod(a - b, M_PI / 2.0);
  if (d >= M_PI / 4.0) d -= M_PI / 2.0;
  if (d < -M_PI / 4.0) d += M_PI / 2.0;
  return d;
}

struct Edge {
  Eigen::Vector2d a, b;
  [[nodiscard]] double length() const { return (b - a).norm(); }
  [[nodiscard]] double angle() const { return std::atan2(b.y() - a.y(), b.x() - a.x()); }
};

std::vector<Edge> long_edges(const Ring2d& ring, double min_edge_m) {
  std::vector<Edge> out;
  const std::size_t n = ring.size();
  for (std::size_t i = 0; i < n; ++i) {
    Edge e{ring[i], ring[(i + 1) % n]};
    if (e.length() >= min_edge_m) out.push_back(e);
  }
  return out;
}

}  // namespace

double clipped_area(const PolygonWithHoles& polygon, double x0, double y0, double x1, double y1) {
  if (x1 <= x0 || y1 <= y0) return 0.0;
  double a = clipped_ring_area(polygon.outer, x0, y0, x1, y1);
  for (const auto& hole : polygon.holes) a -= clipped_ring_area(hole, x0, y0, x1, y1);
  return std::max(0.0, a);
}

namespace layout_detail {

double overlap(const Rect& a, const Rect& b) {
  const double w = std::min(a.x1, b.x1) - std::max(a.x0, b.x0);
  const double h = std::min(a.y1, b.y1) - std::max(a.y0, b.y0);
  return (w > 0 && h > 0) ? w * h : 0.0;
}

Rect bounds_of(const PolygonWithHoles& polygon) {
  Rect b{1e300, 1e300, -1e300, -1e300};
  for (const auto& v : polygon.outer) {
    b.x0 = std::min(b.x0, v.x()); b.x1 = std::max(b.x1, v.x());
    b.y0 = std::min(b.y0, v.y()); b.y1 = std::max(b.y1, v.y());
  }
  return b;
}

LayoutFrame::ToFrame LayoutFrame::to_frame_map() const {
  return {std::cos(theta_rad), std::sin(theta_rad), pivot};
}

Eigen::Vector2d LayoutFrame::to_frame(const Eigen::Vector2d& p) const { return to_frame_map()(p); }

Eigen::Vector2d LayoutFrame::to_layer(const Eigen::Vector2d& q) const {
  const double c = std::cos(theta_rad), s = std::sin(theta_rad);
  return Eigen::Vector2d(c * q.x() - s * q.y(), s * q.x() + c * q.y()) + pivot;
}

PolygonWithHoles LayoutFrame::to_frame(const PolygonWithHoles& polygon) const {
  const ToFrame map = to_frame_map();
  PolygonWithHoles out;
  for (const auto& p : polygon.outer) out.outer.push_back(map(p));
  for (const auto& hole : polygon.holes) {
    Ring2d r;
    for (const auto& p : hole) r.push_back(map(p));
    out.holes.push_back(std::move(r));
  }
  return out;
}

Box2d LayoutFrame::to_layer(const FrameBox& box, const std::vector<BoxFormat>& formats) const {
  Box2d b;
  const Eigen::Vector2d c((box.rect.x0 + box.rect.x1) / 2.0, (box.rect.y0 + box.rect.y1) / 2.0);
  b.center = to_layer(c);
  double yaw = theta_rad + (box.long_along_x ? 0.0 : M_PI / 2.0);
  if (yaw > M_PI / 2.0) yaw -= M_PI;
  b.yaw_rad = yaw;
  b.format = box.format;
  b.long_m = formats[static_cast<std::size_t>(box.format)].long_m;
  b.short_m = formats[static_cast<std::size_t>(box.format)].short_m;
  return b;
}

std::vector<Corner> orthogonal_corners(const PolygonWithHoles& polygon, double angle_tol_deg,
                                       double min_edge_m) {
  std::vector<Corner> out;
  const double tol = angle_tol_deg * M_PI / 180.0;
  auto scan = [&](const Ring2d& ring, bool is_hole) {
    const double orientation = signed_area(ring) >= 0 ? 1.0 : -1.0;
    const std::vector<Edge> edges = long_edges(ring, min_edge_m);
    const std::size_t n = edges.size();
    if (n < 2) return;
    for (std::size_t i = 0; i < n; ++i) {
      const Edge& e0 = edges[i];
      const Edge& e1 = edges[(i + 1) % n];
      const Eigen::Vector2d d0 = (e0.b - e0.a).normalized(), d1 = (e1.b - e1.a).normalized();
      const double turn = std::atan2(d0.x() * d1.y() - d0.y() * d1.x(), d0.dot(d1));
      if (std::abs(std::abs(turn) - M_PI / 2.0) > tol) continue;
      // The gap between the two long edges (rounded corner) must be short.
      if ((e1.a - e0.b).norm() > 2.0 * min_edge_m) continue;
      // Intersection of the two edge lines.
      const double den = d0.x() * d1.y() - d0.y() * d1.x();
      const Eigen::Vector2d w = e1.a - e0.a;
      const double t = (w.x() * d1.y() - w.y() * d1.x()) / den;
      Corner c;
      c.v = e0.a + t * d0;
      c.prev = e0.a;
      c.next = e1.b;
      // The layer lies left of an outer ring traversed counter-clockwise and left of a hole
      // traversed clockwise; a turn toward the layer side is a convex corner of the layer.
      const bool layer_left = is_hole ? orientation < 0 : orientation > 0;
      c.convex = (turn > 0) == layer_left;
      out.push_back(c);
    }
  };
  scan(polygon.outer, false);
  for (const auto& hole : polygon.holes) scan(hole, true);
  return out;
}

std::vector<double> layout_orientations(const PolygonWithHoles& polygon, double angle_tol_deg,
                                        double min_edge_m) {
  const std::vector<Corner> corners = orthogonal_corners(polygon, angle_tol_deg, min_edge_m);
  std::vector<Edge> edges = long_edges(polygon.outer, min_edge_m);
  for (const auto& hole : polygon.holes) {
    auto h = long_edges(hole, min_edge_m);
    edges.insert(edges.end(), h.begin(), h.end());
  }
  const double tol = angle_tol_deg * M_PI / 180.0;
  std::vector<std::pair<double, double>> found;  // (support, theta)
  for (const auto& c : corners) {
    const double seed = wrap_quarter(std::atan2(c.v.y() - c.prev.y(), c.v.x() - c.prev.x()));
    // Length-weighted mean of the edges near the seed (mod 90 deg), two passes.
    double theta = seed, support = 0.0;
    for (int pass = 0; pass < 2; ++pass) {
      double sum = 0.0, wsum = 0.0;
      for (const auto& e : edges) {
        const double d = quarter_diff(e.angle(), theta);
        if (std::abs(d) > (pass == 0 ? tol : tol / 2.0)) continue;
        const double w = e.length() * e.length();
        sum += w * d;
        wsum += w;
      }
      if (wsum > 0) theta = wrap_quarter(theta + sum / wsum);
      support = wsum;
    }
    bool dup = false;
    for (auto& f : found) {
      if (std::abs(quarter_diff(f.second, theta)) < 2.0 * M_PI / 180.0) {
        dup = true;
        break;
      }
    }
    if (!dup) found.emplace_back(support, theta);
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<double> out;
  for (const auto& f : found) out.push_back(f.second);
  return out;
}

AreaOracle::AreaOracle(const PolygonWithHoles& frame_polygon, AreaMethod method, double raster_cell_m,
                       double dilate_m)
    : polygon_(&frame_polygon), method_(method), dilate_m_(std::max(0.0, dilate_m)) {
  if (method_ != AreaMethod::kRaster) return;
  const Rect b = bounds_of(frame_polygon);
  // At most kMaxCells cells (about 40 MB with the summed-area table): a layer of many square
  // metres is rasterised more coarsely.
  constexpr double kMaxCells = 4e6;
  const double extent_m2 = (b.x1 - b.x0 + 2 * dilate_m_) * (b.y1 - b.y0 + 2 * dilate_m_);
  cell_ = std::max({raster_cell_m, 1e-4, std::sqrt(std::max(0.0, extent_m2) / kMaxCells)});
  const int grow = static_cast<int>(std::lround(dilate_m_ / cell_));
  x0_ = b.x0 - cell_ * (1 + grow);
  y0_ = b.y0 - cell_ * (1 + grow);
  w_ = static_cast<int>(std::ceil((b.x1 - b.x0) / cell_)) + 2 + 2 * grow;
  h_ = static_cast<int>(std::ceil((b.y1 - b.y0) / cell_)) + 2 + 2 * grow;
  // The mask is a view of `cells` (the dilation works on the caller's thread, see layer_raster.hpp).
  std::vector<std::uint8_t> cells(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_), 0);
  cv::Mat mask(h_, w_, CV_8U, cells.data());
  constexpr int kShift = 8;
  const double scale = static_cast<double>(1 << kShift) / cell_;
  auto to_pts = [&](const Ring2d& ring) {
    std::vector<cv::Point> pts;
    for (const auto& p : ring) {
      pts.emplace_back(static_cast<int>(std::lround((p.x() - x0_) * scale - 0.5 * (1 << kShift))),
                       static_cast<int>(std::lround((p.y() - y0_) * scale - 0.5 * (1 << kShift))));
    }
    return pts;
  };
  std::vector<std::vector<cv::Point>> outer{to_pts(frame_polygon.outer)};
  cv::fillPoly(mask, outer, cv::Scalar(1), cv::LINE_8, kShift);
  std::vector<std::vector<cv::Point>> holes;
  for (const auto& h : frame_polygon.holes) holes.push_back(to_pts(h));
  if (!holes.empty()) cv::fillPoly(mask, holes, cv::Scalar(0), cv::LINE_8, kShift);
  if (grow > 0) dilate_square(cells, w_, h_, grow);
  integral_into(mask, sat_);
}

double AreaOracle::area(const Rect& r) const {
  if (method_ != AreaMethod::kRaster) return clipped_area(*polygon_, r.x0, r.y0, r.x1, r.y1);
  // Bilinear lookup in the integral image: exact for a density constant per cell.
  const auto W = static_cast<std::size_t>(w_ + 1);
  auto sample = [&](double x, double y) {
    const double fx = std::clamp((x - x0_) / cell_, 0.0, static_cast<double>(w_));
    const double fy = std::clamp((y - y0_) / cell_, 0.0, static_cast<double>(h_));
    const int ix = std::min(static_cast<int>(fx), w_ - 1), iy = std::min(static_cast<int>(fy), h_ - 1);
    const double tx = fx - ix, ty = fy - iy;
    auto at = [&](int row, int col) {
      return sat_[static_cast<std::size_t>(row) * W + static_cast<std::size_t>(col)];
    };
    return (1 - ty) * ((1 - tx) * at(iy, ix) + tx * at(iy, ix + 1)) +
           ty * ((1 - tx) * at(iy + 1, ix) + tx * at(iy + 1, ix + 1));
  };
  const double cells = sample(r.x1, r.y1) - sample(r.x0, r.y1) - sample(r.x1, r.y0) + sample(r.x0, r.y0);
  return std::max(0.0, cells * cell_ * cell_);
}

double rings_length_m(const PolygonWithHoles& polygon) {
  auto length = [](const Ring2d& r) {
    double l = 0.0;
    for (std::size_t i = 0; i < r.size(); ++i) l += (r[(i + 1) % r.size()] - r[i]).norm();
    return l;
  };
  double total = length(polygon.outer);
  for (const auto& h : polygon.holes) total += length(h);
  return total;
}

FormatExtremes format_extremes(const std::vector<BoxFormat>& formats) {
  FormatExtremes e;
  for (std::size_t f = 0; f < formats.size(); ++f) {
    const double a = formats[f].long_m * formats[f].short_m;
    e.min_area_m2 = f == 0 ? a : std::min(e.min_area_m2, a);
    e.min_short_m = f == 0 ? formats[f].short_m : std::min(e.min_short_m, formats[f].short_m);
    e.min_long_m = f == 0 ? formats[f].long_m : std::min(e.min_long_m, formats[f].long_m);
  }
  return e;
}

DistinctFormats distinct_formats(const std::vector<BoxFormat>& formats) {
  DistinctFormats d;
  for (std::size_t f = 0; f < formats.size(); ++f) {
    const BoxFormat& a = formats[f];
    if (std::any_of(d.formats.begin(), d.formats.end(),
                    [&](const BoxFormat& b) { return same_carton(a, b); }))
      continue;
    d.formats.push_back(a);
    d.original.push_back(static_cast<int>(f));
  }
  return d;
}

double line_merge_tol_m(const LayoutParams& params, double min_short_m) {
  return params.search.line_merge_tol_m > 0 ? params.search.line_merge_tol_m : std::clamp(0.06 * min_short_m, 0.006, 0.02);
}

double min_corner_edge_m(double min_short_m) { return std::max(0.02, 0.25 * min_short_m); }

double tie_margin_m2(const LayoutParams& params, const std::vector<BoxFormat>& formats) {
  const FormatExtremes e = format_extremes(formats);
  return params.search.ambiguity_margin * e.min_area_m2 + std::max(0.0, params.search.outline_tolerance_m) * e.min_short_m;
}

PolygonWithHoles simplified(const PolygonWithHoles& polygon, double tolerance_m) {
  auto ring = [&](const Ring2d& r) {
    if (r.size() < 8) return r;
    std::vector<cv::Point2f> in, out;
    for (const auto& p : r) in.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    cv::approxPolyDP(in, out, tolerance_m, true);
    if (out.size() < 3) return r;
    Ring2d s;
    for (const auto& p : out) s.emplace_back(p.x, p.y);
    return s;
  };
  PolygonWithHoles out;
  out.outer = ring(polygon.outer);
  for (const auto& h : polygon.holes) out.holes.push_back(ring(h));
  return out;
}

bool same_layout(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b, double tol_m) {
  if (a.size() != b.size()) return false;
  std::vector<bool> used(b.size(), false);
  for (const auto& x : a) {
    const double cx = (x.rect.x0 + x.rect.x1) / 2, cy = (x.rect.y0 + x.rect.y1) / 2;
    bool hit = false;
    for (std::size_t j = 0; j < b.size(); ++j) {
      if (used[j] || b[j].format != x.format || b[j].long_along_x != x.long_along_x) continue;
      const double dx = (b[j].rect.x0 + b[j].rect.x1) / 2 - cx, dy = (b[j].rect.y0 + b[j].rect.y1) / 2 - cy;
      if (std::hypot(dx, dy) < tol_m) {
        used[j] = true;
        hit = true;
        break;
      }
    }
    if (!hit) return false;
  }
  return true;
}

}  // namespace layout_detail
}  // namespace palletd
