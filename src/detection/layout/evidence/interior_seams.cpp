// How much of a layout's interior box sides the seam raster (or a gap in the outline) shows as seams. Cartons
// side by side leave a gap or at least the groove of their rounded edges, which the depth (a dip) or the
// intensity image (a dark line) shows wherever the sensor resolves it; a slip sheet over the
// layer is one flat surface and shows none; cartons pressed together still show the tape along
// their flaps in the intensity image where a sheet is plain.
#include <algorithm>
#include <cmath>

#include "palletd/detection/layout.hpp"

#include "evidence/tape.hpp"

namespace palletd {
namespace {

/// Corners are left out: boxes' corners meet there and outline sides end [m].
constexpr double kCornerMargin_m = 0.02;
/// A side is interior when a neighbour's top lies this far beyond it (gaps up to ~20 mm) [m].
constexpr double kNeighbourProbe_m = 0.015;
/// Tolerance of the neighbour's footprint [m].
constexpr double kFootprintTol_m = 0.005;
/// A seam is looked for from this far inside the box to the probe distance outside [m].
constexpr double kSeamInside_m = 0.006;
/// Where a gap in the layer's outline between two boxes is looked for, beyond the side [m].
constexpr double kGapProbes_m[] = {0.003, 0.007, 0.011};

bool inside_box(const Box2d& b, const Eigen::Vector2d& p_m, double tol_m) {
  const Eigen::Vector2d d = p_m - b.center;
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  const double along = c * d.x() + s * d.y();
  const double across = -s * d.x() + c * d.y();
  return std::abs(along) <= 0.5 * b.long_m + tol_m && std::abs(across) <= 0.5 * b.short_m + tol_m;
}

double seam_at(const SeamEvidence& seams, const Eigen::Vector2d& p_m) {
  const auto ix = static_cast<int>(std::floor((p_m.x() - seams.origin_m.x()) / seams.cell_m));
  const auto iy = static_cast<int>(std::floor((p_m.y() - seams.origin_m.y()) / seams.cell_m));
  if (ix < 0 || iy < 0 || ix >= seams.width || iy >= seams.height) return 0.0;
  return static_cast<double>(seams.at(ix, iy));
}

/// Even-odd test of a point against a ring.
bool in_ring(const Ring2d& ring, const Eigen::Vector2d& p) {
  bool in = false;
  for (std::size_t i = 0, j = ring.size() - 1; i < ring.size(); j = i++) {
    const Eigen::Vector2d& a = ring[i];
    const Eigen::Vector2d& b = ring[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

bool on_layer(const std::vector<PolygonWithHoles>& polygons, const Eigen::Vector2d& p) {
  for (const PolygonWithHoles& polygon : polygons) {
    if (polygon.outer.size() < 3 || !in_ring(polygon.outer, p)) continue;
    bool in_hole = false;
    for (const Ring2d& hole : polygon.holes) in_hole = in_hole || (hole.size() >= 3 && in_ring(hole, p));
    if (!in_hole) return true;
  }
  return false;
}

bool has_neighbour(const std::vector<LayoutBox>& boxes, std::size_t self, const Eigen::Vector2d& p_m) {
  for (std::size_t j = 0; j < boxes.size(); ++j)
    if (j != self && inside_box(boxes[j], p_m, kFootprintTol_m)) return true;
  return false;
}

}  // namespace

InteriorSeams measure_interior_seams(const std::vector<LayoutBox>& boxes, const SeamEvidence& seams,
                                     const std::vector<PolygonWithHoles>& polygons) {
  InteriorSeams out;
  if (seams.empty() || !(seams.cell_m > 0.0)) return out;
  const double step_m = std::max(seams.cell_m, 0.002);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Box2d& b = boxes[i];
    const Eigen::Vector2d along(std::cos(b.yaw_rad), std::sin(b.yaw_rad));
    const Eigen::Vector2d across(-along.y(), along.x());
    // The four sides: outward normal, half extent along it, direction and half length of the side.
    const struct {
      Eigen::Vector2d n;
      double e_n;
      Eigen::Vector2d t;
      double e_t;
    } sides[4] = {{along, 0.5 * b.long_m, across, 0.5 * b.short_m},
                  {-along, 0.5 * b.long_m, across, 0.5 * b.short_m},
                  {across, 0.5 * b.short_m, along, 0.5 * b.long_m},
                  {-across, 0.5 * b.short_m, along, 0.5 * b.long_m}};
    for (const auto& side : sides) {
      for (double s = -side.e_t + kCornerMargin_m; s <= side.e_t - kCornerMargin_m; s += step_m) {
        const Eigen::Vector2d q = b.center + side.n * side.e_n + side.t * s;
        if (!has_neighbour(boxes, i, q + side.n * kNeighbourProbe_m)) continue;
        out.length_m += step_m;
        // A seam: a seam-like cell near the side, or a gap the layer's outline leaves between the
        // two boxes (a gap wide enough to show as off-layer is the clearest seam).
        bool seen = false;
        for (double d = -kSeamInside_m; d <= kNeighbourProbe_m && !seen; d += 0.5 * seams.cell_m)
          seen = seam_at(seams, q + side.n * d) > 0.5;
        for (const double d : kGapProbes_m) seen = seen || !on_layer(polygons, q + side.n * d);
        if (seen) out.seen_m += step_m;
      }
    }
  }
  if (out.length_m > 0.0 && out.seen_share() < InteriorSeams::kTapeAskedShare) {
    out.taped_boxes = static_cast<std::size_t>(std::count_if(
        boxes.begin(), boxes.end(), [&](const LayoutBox& b) { return layout_detail::taped(b, seams); }));
  }
  return out;
}

}  // namespace palletd
