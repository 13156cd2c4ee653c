// trim_fattened_edges(): the outline inset with CGAL's straight skeleton, the points beyond it
// and near the layer's edge in the image dropped through a raster of the inset outline.
#include "fattened_edges.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_with_holes_2.h>
#include <CGAL/arrange_offset_polygons_2.h>
#include <CGAL/create_offset_polygons_2.h>
#include <CGAL/create_straight_skeleton_2.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/core/timing.hpp"

#include "edge_offset.hpp"
#include "layer_raster.hpp"

namespace palletd {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalPolygon = CGAL::Polygon_2<Kernel>;
using CgalPolygonWithHoles = CGAL::Polygon_with_holes_2<Kernel>;

constexpr double kRaster_m = 0.001;  ///< cell of the raster that keeps or drops layer points [m]

CgalPolygon to_cgal(const Ring2d& ring, bool counter_clockwise) {
  CgalPolygon out;
  for (const Eigen::Vector2d& p : ring) out.push_back(Kernel::Point_2(p.x(), p.y()));
  if (out.is_simple() && (out.orientation() == CGAL::COUNTERCLOCKWISE) != counter_clockwise)
    out.reverse_orientation();
  return out;
}

Ring2d from_cgal(const CgalPolygon& polygon) {
  Ring2d ring;
  for (auto v = polygon.vertices_begin(); v != polygon.vertices_end(); ++v)
    ring.emplace_back(CGAL::to_double(v->x()), CGAL::to_double(v->y()));
  return ring;
}

void translate(PolygonWithHoles& polygon, const Eigen::Vector2d& by_m) {
  for (Eigen::Vector2d& p : polygon.outer) p += by_m;
  for (Ring2d& hole : polygon.holes)
    for (Eigen::Vector2d& p : hole) p += by_m;
}

/// Whether an edge of `a` meets an edge of `b`.
bool rings_meet(const CgalPolygon& a, const CgalPolygon& b) {
  for (auto ea = a.edges_begin(); ea != a.edges_end(); ++ea)
    for (auto eb = b.edges_begin(); eb != b.edges_end(); ++eb)
      if (CGAL::do_intersect(*ea, *eb)) return true;
  return false;
}

/// The holes the skeleton can take: simple, strictly inside the outer ring, meeting neither it
/// nor a larger hole kept before them (the layer's holes come from separate contours and may
/// touch). The skeleton of rings that meet is not built.
std::vector<CgalPolygon> valid_holes(const CgalPolygon& outer, const std::vector<Ring2d>& holes) {
  std::vector<CgalPolygon> candidates, kept;
  for (const Ring2d& hole : holes) {
    CgalPolygon h = to_cgal(hole, false);
    if (h.size() >= 3 && h.is_simple()) candidates.push_back(std::move(h));
  }
  std::sort(candidates.begin(), candidates.end(), [](const CgalPolygon& a, const CgalPolygon& b) {
    return CGAL::abs(a.area()) > CGAL::abs(b.area());
  });
  for (CgalPolygon& h : candidates) {
    if (outer.bounded_side(h.vertex(0)) != CGAL::ON_BOUNDED_SIDE || rings_meet(h, outer)) continue;
    const bool meets_kept = std::any_of(kept.begin(), kept.end(), [&](const CgalPolygon& k) {
      return rings_meet(h, k) || k.bounded_side(h.vertex(0)) != CGAL::ON_UNBOUNDED_SIDE ||
             h.bounded_side(k.vertex(0)) != CGAL::ON_UNBOUNDED_SIDE;
    });
    if (!meets_kept) kept.push_back(std::move(h));
  }
  return kept;
}

/// The polygon moved in by inset_m; a piece narrower than twice the inset disappears. An outline
/// that is not simple, or whose skeleton CGAL cannot build, is left as it is.
std::vector<PolygonWithHoles> inset(const PolygonWithHoles& polygon, double inset_m) {
  const CgalPolygon outer = to_cgal(polygon.outer, true);
  if (outer.size() < 3 || !outer.is_simple()) return {polygon};
  const std::vector<CgalPolygon> holes = valid_holes(outer, polygon.holes);
  const auto skeleton = CGAL::create_interior_straight_skeleton_2(
      outer.vertices_begin(), outer.vertices_end(), holes.begin(), holes.end(), Kernel());
  if (!skeleton) return {polygon};
  const auto offsets = CGAL::create_offset_polygons_2<CgalPolygon>(inset_m, *skeleton, Kernel());
  std::vector<PolygonWithHoles> out;
  for (const auto& piece : CGAL::arrange_offset_polygons_2<CgalPolygonWithHoles>(offsets)) {
    PolygonWithHoles p{from_cgal(piece->outer_boundary()), {}};
    for (auto h = piece->holes_begin(); h != piece->holes_end(); ++h) p.holes.push_back(from_cgal(*h));
    out.push_back(std::move(p));
  }
  return out;
}

/// Pixels without a measurement whose four neighbours are all layer points count as layer: a
/// single dropout inside a top is no edge.
void fill_dropouts(const Frame& frame, int u0, int v0, cv::Mat1b& mask) {
  const cv::Mat1b seen = mask.clone();
  for (int r = 1; r + 1 < mask.rows; ++r) {
    for (int c = 1; c + 1 < mask.cols; ++c) {
      if (seen(r, c) != 0) continue;
      const std::size_t i =
          static_cast<std::size_t>(v0 + r - 1) * static_cast<std::size_t>(frame.intrinsics.width) +
          static_cast<std::size_t>(u0 + c - 1);
      if (frame.depth[i] != 0) continue;
      if (seen(r - 1, c) != 0 && seen(r + 1, c) != 0 && seen(r, c - 1) != 0 && seen(r, c + 1) != 0)
        mask(r, c) = 255;
    }
  }
}

/// Each layer point's distance in the image to the nearest pixel that is no layer point (the
/// layer's edge, a hole) [pixels]; -1 without the points' pixels.
std::vector<float> distance_to_edge_px(const Frame& frame, const LayerResult& layer) {
  const Intrinsics& in = frame.intrinsics;
  std::vector<float> out(layer.points_2d.size(), -1.0F);
  if (layer.point_pixels.size() != layer.points_2d.size() || in.width <= 0) return out;
  int u0 = in.width, v0 = in.height, u1 = -1, v1 = -1;
  for (const std::int32_t px : layer.point_pixels) {
    u0 = std::min(u0, px % in.width), u1 = std::max(u1, px % in.width);
    v0 = std::min(v0, px / in.width), v1 = std::max(v1, px / in.width);
  }
  if (u1 < u0) return out;
  // One pixel of no layer around the window: the layer's edge where the window ends.
  cv::Mat1b mask(v1 - v0 + 3, u1 - u0 + 3, static_cast<std::uint8_t>(0));
  for (const std::int32_t px : layer.point_pixels) mask(px / in.width - v0 + 1, px % in.width - u0 + 1) = 255;
  if (frame.depth.size() == static_cast<std::size_t>(in.width) * static_cast<std::size_t>(in.height))
    fill_dropouts(frame, u0, v0, mask);
  cv::Mat1f distance;
  cv::distanceTransform(mask, distance, cv::DIST_L2, cv::DIST_MASK_5);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const std::int32_t px = layer.point_pixels[i];
    out[i] = distance(px / in.width - v0 + 1, px % in.width - u0 + 1);
  }
  return out;
}

/// Keeps the layer points (and their pixels) that lie inside `polygons`, and those further than
/// `keep_beyond_px` from the layer's edge in the image: the fattened band lies along the points'
/// own edge, and where the simplified outline cuts a corner or steps inward at a seam, the carton
/// top it leaves out is still carton top (the refinement reads the box's side where its points end).
void keep_points_inside(const std::vector<PolygonWithHoles>& polygons, const Frame& frame,
                        double keep_beyond_px, LayerResult& layer) {
  const std::vector<float> edge_px = distance_to_edge_px(frame, layer);
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const PolygonWithHoles& p : polygons)
    for (const Eigen::Vector2d& v : p.outer) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
  if (!(hi.x() > lo.x() && hi.y() > lo.y())) return;
  const int w = static_cast<int>(std::ceil((hi.x() - lo.x()) / kRaster_m)) + 1;
  const int h = static_cast<int>(std::ceil((hi.y() - lo.y()) / kRaster_m)) + 1;
  cv::Mat1b inside(h, w, static_cast<std::uint8_t>(0));
  std::vector<std::vector<cv::Point>> rings;
  const auto to_cell = [&](const Eigen::Vector2d& v) {
    return cv::Point(static_cast<int>(std::lround((v.x() - lo.x()) / kRaster_m)),
                     static_cast<int>(std::lround((v.y() - lo.y()) / kRaster_m)));
  };
  for (const PolygonWithHoles& p : polygons) {
    rings.emplace_back();
    for (const Eigen::Vector2d& v : p.outer) rings.back().push_back(to_cell(v));
    for (const Ring2d& hole : p.holes) {
      rings.emplace_back();
      for (const Eigen::Vector2d& v : hole) rings.back().push_back(to_cell(v));
    }
  }
  cv::fillPoly(inside, rings, cv::Scalar(1));  // even-odd: holes stay empty
  std::size_t kept = 0;
  for (std::size_t i = 0; i < layer.points_2d.size(); ++i) {
    const Eigen::Vector2f& q = layer.points_2d[i];
    const cv::Point c = to_cell(q.cast<double>());
    const bool deep = edge_px[i] > keep_beyond_px;
    if (!deep && (c.x < 0 || c.y < 0 || c.x >= w || c.y >= h || inside(c) == 0)) continue;
    layer.points_2d[kept] = q;
    if (i < layer.point_pixels.size()) layer.point_pixels[kept] = layer.point_pixels[i];
    ++kept;
  }
  layer.points_2d.resize(kept);
  layer.point_pixels.resize(std::min(kept, layer.point_pixels.size()));
}

/// Stage 5b itself (trim_fattened_edges() times it).
LayerResult trim_edges(const Frame& frame, LayerResult layer, const LayerParams& params) {
  if (layer.status != DetectionStatus::kOk || !(params.fattened_edge_min_px > 0.0)) return layer;
  const EdgeOffset edges = intensity_edge_offset(frame, layer);
  if (edges.samples == 0) return layer;
  layer.diagnostics.edge_offset_m = edges.offset_m;
  const double pitch_m = layout_detail::layer_pixel_pitch_m(frame.intrinsics, layer);
  if (!(edges.offset_m > params.fattened_edge_min_px * pitch_m) ||
      edges.offset_m > params.fattened_edge_max_px * pitch_m)
    return layer;
  std::vector<PolygonWithHoles> moved;
  for (const PolygonWithHoles& polygon : layer.polygons) {
    if (!(edges.inset_m > 0.0)) {
      moved.push_back(polygon);
      continue;
    }
    for (PolygonWithHoles& piece : inset(polygon, edges.inset_m)) moved.push_back(std::move(piece));
  }
  if (moved.empty()) return layer;  // nothing left: the offset is no fattening of these tops
  for (PolygonWithHoles& piece : moved) translate(piece, -edges.shift_m);
  layer.polygons = std::move(moved);
  // Half a pixel over the trim: the points of a straight edge stray about that far from its line.
  keep_points_inside(layer.polygons, frame, (edges.inset_m + edges.shift_m.norm()) / pitch_m + 0.5, layer);
  layer.diagnostics.edges_moved_in_m = edges.inset_m;
  layer.diagnostics.edges_shifted_m = edges.shift_m.norm();
  return layer;
}

}  // namespace

LayerResult trim_fattened_edges(const Frame& frame, LayerResult layer, const LayerParams& params) {
  const auto t_start = std::chrono::steady_clock::now();
  layer = trim_edges(frame, std::move(layer), params);
  layer.diagnostics.t_edges_ms = ms_since(t_start);
  return layer;
}

}  // namespace palletd
