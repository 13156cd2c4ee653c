// Internals of check_pick(): what a frame shows at the layer's height, on a grid in the layer
// frame, and where a box's sides step down.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd::pick_check {

/// A layer point counts as a box top within this band of the last layer's plane, as a gap or a
/// lower level this far below it.
constexpr double kBand_m = 0.012, kDrop_m = 0.025;

/// The grid's cell for frames of `intrinsics` over `layer`: one cell per pixel on the layer, 2 mm
/// at least. Finer cells leave empty cells between the pixels, and a side's step would be read
/// from whichever top cell a line across it last hit.
double grid_cell_m(const Intrinsics& intrinsics, const LayerResult& layer);

/// What the frame shows in one cell of the grid.
enum class Seen : std::uint8_t {
  kUnknown = 0,  ///< no point (no depth, hidden, between pixels)
  kTop = 1,      ///< a point at the layer's height: a box top
  kLower = 2,    ///< only points clearly below it: a gap, the next level, the floor
};

/// A grid over part of the layer plane (layer frame, 2 mm cells).
class Grid {
 public:
  Grid(const Eigen::Vector2d& lo_m, const Eigen::Vector2d& hi_m, double cell_m);
  /// Adds the frame's points: at the layer's height (within `band_m`) a top, more than
  /// `drop_m` below it a lower cell (a top in the same cell wins).
  void add_frame(const Frame& frame, const RayTable& rays, const Eigen::Isometry3d& T_layer_camera,
                 double band_m, double drop_m);
  [[nodiscard]] Seen at(const Eigen::Vector2d& p_m) const {
    const std::ptrdiff_t k = index(p_m);
    return k < 0 ? Seen::kUnknown : cells_[static_cast<std::size_t>(k)];
  }
  /// The layer point that made the cell at p_m a top (the first one), nullptr where it is none.
  [[nodiscard]] const Eigen::Vector2f* top_point(const Eigen::Vector2d& p_m) const {
    const std::ptrdiff_t k = index(p_m);
    if (k < 0 || cells_[static_cast<std::size_t>(k)] != Seen::kTop) return nullptr;
    return &top_points_[static_cast<std::size_t>(k)];
  }
  [[nodiscard]] double cell_m() const { return 1.0 / inv_cell_; }

 private:
  /// The cell's index, -1 outside the grid.
  [[nodiscard]] std::ptrdiff_t index(const Eigen::Vector2d& p_m) const {
    const double fx = (p_m.x() - lo_m_.x()) * inv_cell_, fy = (p_m.y() - lo_m_.y()) * inv_cell_;
    if (!(fx >= 0.0 && fy >= 0.0 && fx < nx_ && fy < ny_)) return -1;
    return static_cast<std::ptrdiff_t>(fy) * nx_ + static_cast<std::ptrdiff_t>(fx);
  }
  Eigen::Vector2d lo_m_;
  double inv_cell_;  ///< 1 / the cell size [1/m]
  int nx_ = 0, ny_ = 0;
  std::vector<Seen> cells_;
  std::vector<Eigen::Vector2f> top_points_;  ///< per cell, the point of a top cell [m]
};

/// Share of the rectangle's seen cells (top or lower) that are top, inset by `inset_m`;
/// `seen_cells` counts the cells that were seen at all. Cells inside `taken_by_others` (other
/// boxes where they stand now) are left out: their top is not this box's.
double top_share(const Grid& grid, const Box2d& box, double inset_m, int& seen_cells,
                 const std::vector<Box2d>& taken_by_others = {});

/// One edge measurement: a point on the box's side (box frame), its outward normal (box frame),
/// and how far outward of the side the step down was found [m].
struct EdgeSample {
  Eigen::Vector2d point_box = Eigen::Vector2d::Zero();
  Eigen::Vector2d normal_box = Eigen::Vector2d::UnitX();
  int side = 0;  ///< 0 +long, 1 -long, 2 +short, 3 -short
  double offset_m = 0.0;
};

/// Between the lines across a side that edge_samples() reads [m].
constexpr double kSampleSpacing_m = 0.010;

/// Where the box's sides step down in the grid, along lines across each side every 10 mm,
/// looking `reach_m` inward and outward: the outermost top point within a cell of the line
/// before the first lower cell on it (a pixel straddling the edge is the side's last top point,
/// wherever the grid's cells cut the pixels); the lower cell may lie further out than the reach
/// where no cell between shows anything (the side's shadow over a deep hole). A side that abuts
/// another box's top shows no step.
/// Samples come in a fixed order (side, then position), with nullopt where no step was found.
std::vector<std::optional<EdgeSample>> edge_samples(const Grid& grid, const Box2d& box, double reach_m);

/// The box's move (box frame: shift along its long and short sides [m], turn [rad]) that best
/// explains how its sides moved (robust least squares; a direction no side constrains stays 0),
/// and its covariance from the samples' scatter: all samples', or an axis's own where its samples
/// (the sides across the box's length, or across its width) scatter more. Samples closer along a
/// side than `correlated_m` read the same pixels (a coarse pitch, a step taken from a cell beside
/// the line): the scatter counts one independent sample per `correlated_m`, not one per line.
struct Move {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();  ///< the fit's normal matrix (weights)
  /// x against its covariance (squared Mahalanobis length): above 16, a move beyond 4 sigma.
  [[nodiscard]] double significance() const { return x.dot(covariance.ldlt().solve(x)); }
};
Move fit_move(const std::vector<EdgeSample>& moves, double correlated_m);

/// d(side offset) / d(move) of a sample: along the side's normal, and the turn's lever.
Eigen::Vector3d move_jacobian(const EdgeSample& sample);

}  // namespace palletd::pick_check
