// Test and benchmark fixtures for the layout search: known layouts, their exact outlines
// (union of the boxes), noise, synthetic seam rasters, matching of found boxes to the truth,
// refinement input around a block of boxes.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "palletd/core/geometry.hpp"
#include "palletd/detection/layer.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd::layout_test {

/// A box of a known layout, axis-aligned before the layout's pose is applied [m].
struct TruthBox {
  double x0, y0;        ///< lower-left corner [m]
  int format;
  bool long_along_x;
};

struct KnownLayout {
  std::string name;
  std::vector<BoxFormat> formats;
  std::vector<TruthBox> boxes;
  double theta_rad = 0.0;                       ///< pose of the layout in the layer frame
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();
  double gap_m = 0.0;  ///< spacing added per grid step between boxes [m] (grid-like layouts only)
};

/// The true boxes in the layer frame.
std::vector<Box2d> truth_boxes(const KnownLayout& layout);
/// Exact outline of the union of the boxes, one polygon with holes per connected component.
std::vector<PolygonWithHoles> union_outline(const KnownLayout& layout);
/// Vertices moved by uniform noise of +/- amplitude_m, corners cut by chamfers of chamfer_m.
std::vector<PolygonWithHoles> perturb(const std::vector<PolygonWithHoles>& polygons, double amplitude_m,
                                      double chamfer_m, unsigned seed);
/// Seam raster: value 1 within half_width_m of every edge shared by two boxes.
SeamEvidence synthetic_seams(const KnownLayout& layout, double cell_m, double half_width_m);
/// `seams` with the tops' intensity: board of 1000 counts, and a band of tape 48 mm wide and 30 %
/// darker along the middle (long axis) of every carton of `layout`, as regular slotted cartons
/// are closed.
SeamEvidence taped(SeamEvidence seams, const KnownLayout& layout);
/// Layer points on a regular grid of pitch_m inside the boxes (the measured top faces).
std::vector<Eigen::Vector2f> layer_points(const KnownLayout& layout, double pitch_m);

/// Largest centre error [m] over the truth boxes when every truth box has a found twin with the
/// same format and orientation (within 2 deg) and the counts match; a negative value otherwise.
double match_error_boxes(const std::vector<Box2d>& truth, const std::vector<Box2d>& found);
/// The same for any boxes that are Box2d (truth boxes, LayoutBox).
template <typename T, typename F>
double match_error(const std::vector<T>& truth, const std::vector<F>& found) {
  return match_error_boxes(std::vector<Box2d>(truth.begin(), truth.end()), std::vector<Box2d>(found.begin(), found.end()));
}

/// Axis-aligned rectangle in the layer frame [m].
struct Rect2d {
  double x0, y0, x1, y1;
};

/// Whether the rectangle lo..hi lies at least margin_m inside `r` (build_seam_evidence leaves
/// the cells that near the outline at zero).
bool inside_by(const Rect2d& r, double margin_m, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi);

/// A cell of a seam raster: its lower-left corner and its centre, layer frame [m].
struct SeamCell {
  Eigen::Vector2d min_m, center_m;
};

/// What refine_layout is given for a block of boxes.
struct RefineInput {
  LayerResult layer;
  LayoutResult found;
  SeamEvidence seams;
};

/// Refinement input for a block of boxes whose layer outline is the rectangle `outline`:
/// - layer: status ok, `outline` as its one polygon, no layer points (the caller adds them);
/// - seams: cells of cell_m, cell (0, 0) at origin_m, over `outline` grown by 20 mm on each side;
///   seam_share(cell) gives each cell's value (0..1), called once per cell, row by row from the
///   lower left; strength = share of the cells above 0.5;
/// - found: the search's answer, cols x rows boxes of the nominal format (long side along x,
///   format 0) packed from the outline's lower-left corner.
RefineInput packed_block_input(const Rect2d& outline, int cols, int rows, const BoxFormat& nominal,
                               const Eigen::Vector2d& origin_m, double cell_m,
                               const std::function<float(const SeamCell&)>& seam_share);

// Layouts used by the tests and the benchmark.
KnownLayout block(int cols, int rows, double long_m, double short_m);
KnownLayout pinwheel(double long_m, double short_m, bool mirrored);  ///< 4 boxes around a hole
KnownLayout brick();          ///< rows of long boxes and a row of turned boxes, 1200 x 1000
KnownLayout mixed_formats();  ///< two formats in one layer
KnownLayout l_shaped();       ///< a 3 x 3 block with two boxes picked
KnownLayout clusters();       ///< three separate groups
KnownLayout grid_200x150(int n_boxes);  ///< n boxes of 200 x 150 filling a 1200 x 1000 layer row by row

}  // namespace palletd::layout_test
