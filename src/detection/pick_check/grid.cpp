// What a frame shows at the layer's height, and where a box's sides step down (check_internal.hpp).
#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "check_internal.hpp"
#include "layer_raster.hpp"

namespace palletd::pick_check {

double grid_cell_m(const Intrinsics& intrinsics, const LayerResult& layer) {
  constexpr double kMinCell_m = 0.002;
  return std::max(kMinCell_m, layout_detail::layer_pixel_pitch_m(intrinsics, layer));
}

Grid::Grid(const Eigen::Vector2d& lo_m, const Eigen::Vector2d& hi_m, double cell_m)
    : lo_m_(lo_m), inv_cell_(1.0 / cell_m) {
  nx_ = std::max(1, static_cast<int>(std::ceil((hi_m.x() - lo_m.x()) / cell_m)));
  ny_ = std::max(1, static_cast<int>(std::ceil((hi_m.y() - lo_m.y()) / cell_m)));
  cells_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_), Seen::kUnknown);
  top_points_.assign(cells_.size(), Eigen::Vector2f::Zero());
}

void Grid::add_frame(const Frame& frame, const RayTable& rays, const Eigen::Isometry3d& T_layer_camera,
                     double band_m, double drop_m) {
  // Per pixel: its height over the layer first (most pixels are decided by it), then its cell.
  const Eigen::Matrix3d R = T_layer_camera.linear();
  const Eigen::Vector3d t = T_layer_camera.translation();
  for (std::size_t i = 0; i < frame.pixel_count(); ++i) {
    if (frame.depth[i] == 0) continue;
    const double z_m = static_cast<double>(frame.depth[i]) * frame.depth_scale_m;
    const double x_m = static_cast<double>(rays.ray(i).x()) * z_m,
                 y_m = static_cast<double>(rays.ray(i).y()) * z_m;
    const double qz = R(2, 0) * x_m + R(2, 1) * y_m + R(2, 2) * z_m + t.z();
    Seen seen = Seen::kUnknown;
    if (std::abs(qz) <= band_m)
      seen = Seen::kTop;
    else if (qz < -drop_m)
      seen = Seen::kLower;
    else
      continue;
    const Eigen::Vector2d q(R(0, 0) * x_m + R(0, 1) * y_m + R(0, 2) * z_m + t.x(),
                            R(1, 0) * x_m + R(1, 1) * y_m + R(1, 2) * z_m + t.y());
    const std::ptrdiff_t k = index(q);
    if (k < 0) continue;
    Seen& cell = cells_[static_cast<std::size_t>(k)];
    if (cell == Seen::kTop) continue;
    cell = seen;
    if (seen == Seen::kTop) top_points_[static_cast<std::size_t>(k)] = q.cast<float>();
  }
}

namespace {

bool inside(const Box2d& box, const Eigen::Vector2d& p_m) {
  const Eigen::Vector2d q = Eigen::Rotation2Dd(-box.yaw_rad) * (p_m - box.center);
  return std::abs(q.x()) <= 0.5 * box.long_m && std::abs(q.y()) <= 0.5 * box.short_m;
}

}  // namespace

double top_share(const Grid& grid, const Box2d& box, double inset_m, int& seen_cells,
                 const std::vector<Box2d>& taken_by_others) {
  const Eigen::Vector2d u(std::cos(box.yaw_rad), std::sin(box.yaw_rad)), v(-u.y(), u.x());
  const double a = 0.5 * box.long_m - inset_m, b = 0.5 * box.short_m - inset_m;
  int top = 0;
  seen_cells = 0;
  constexpr double kStep_m = 0.004;
  for (double x = -a; x <= a; x += kStep_m) {
    for (double y = -b; y <= b; y += kStep_m) {
      const Eigen::Vector2d p_m = box.center + x * u + y * v;
      const Seen s = grid.at(p_m);
      if (s == Seen::kUnknown) continue;
      if (std::any_of(taken_by_others.begin(), taken_by_others.end(),
                      [&](const Box2d& other) { return inside(other, p_m); }))
        continue;
      ++seen_cells;
      top += s == Seen::kTop ? 1 : 0;
    }
  }
  return seen_cells > 0 ? static_cast<double>(top) / seen_cells : 0.0;
}

namespace {

/// How far past the reach a side's shadow may hide the lower level [m]: a camera 20-30 degrees
/// off a side that drops one carton (150-400 mm) into a hole a pick left sees nothing below it
/// for 50-230 mm beyond the side (the stereo camera's second view hides more); with the 60 mm
/// reach the check covers 180 mm.
constexpr double kShadow_m = 0.12;

/// Where, along the line p + s n for s in [-reach, reach], the top ends before the first lower
/// cell (the step down): at the outermost top point (along n) in the cells the line crosses and
/// their neighbours one cell to either side along t. A grid of one cell per pixel leaves cells
/// between the pixels empty, so the line alone may miss the pixel that straddles the edge. Cells
/// between may be unknown, the side's own shadow where the camera looks past the edge, so the
/// lower cell says only that the step came before it; past the reach, up to kShadow_m further,
/// too. nullopt without one.
std::optional<double> step_along(const Grid& grid, const Eigen::Vector2d& p, const Eigen::Vector2d& n,
                                 const Eigen::Vector2d& t, double reach_m) {
  // Half a cell: every cell the line crosses is looked at; where the step lies comes from the
  // points, not from the stepping.
  const double step_m = std::max(0.002, 0.5 * grid.cell_m());
  const Eigen::Vector2d beside = grid.cell_m() * t;
  std::optional<double> outermost;
  for (double s = -reach_m; s <= reach_m; s += step_m) {
    const Eigen::Vector2d at = p + s * n;
    bool top = false;
    auto take = [&](const Eigen::Vector2d& c) {
      const Eigen::Vector2f* q = grid.top_point(c);
      if (q == nullptr) return;
      top = true;
      const double along_n = (q->cast<double>() - p).dot(n);
      outermost = outermost ? std::max(*outermost, along_n) : along_n;
    };
    take(at);
    if (!top) {  // the cells beside count where the line's own cell is no top: a hole, the edge
      take(at - beside);
      take(at + beside);
    }
    if (!top && outermost && grid.at(at) == Seen::kLower) return outermost;
  }
  if (!outermost) return std::nullopt;
  // Past the reach only the lower level may still come: the side's shadow where the camera looks
  // past a tall step (a deep hole a pick left) hides it further out than the reach. A top there
  // is another box's: no step.
  for (double s = reach_m + step_m; s <= reach_m + kShadow_m; s += step_m) {
    const Eigen::Vector2d at = p + s * n;
    const Seen seen = grid.at(at);
    if (seen == Seen::kTop || grid.at(at - beside) == Seen::kTop || grid.at(at + beside) == Seen::kTop)
      return std::nullopt;
    if (seen == Seen::kLower) return outermost;
  }
  return std::nullopt;
}

}  // namespace

std::vector<std::optional<EdgeSample>> edge_samples(const Grid& grid, const Box2d& box, double reach_m) {
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(box.yaw_rad).toRotationMatrix();
  const double half[2] = {0.5 * box.long_m, 0.5 * box.short_m};
  std::vector<std::optional<EdgeSample>> out;
  constexpr double kCornerKeepOut_m = 0.015;
  for (int side = 0; side < 4; ++side) {
    const int axis = side / 2;
    const double sign = side % 2 == 0 ? 1.0 : -1.0;
    Eigen::Vector2d n_box = Eigen::Vector2d::Zero(), t_box = Eigen::Vector2d::Zero();
    n_box[axis] = sign;
    t_box[1 - axis] = 1.0;
    const double along_half = half[1 - axis] - kCornerKeepOut_m;
    for (double a = -along_half; a <= along_half + 1e-9; a += kSampleSpacing_m) {
      Eigen::Vector2d p_box = Eigen::Vector2d::Zero();
      p_box[axis] = sign * half[axis];
      p_box[1 - axis] = a;
      const std::optional<double> step =
          step_along(grid, box.center + R * p_box, R * n_box, R * t_box, reach_m);
      if (!step) {
        out.emplace_back(std::nullopt);
        continue;
      }
      out.push_back(EdgeSample{p_box, n_box, side, *step});
    }
  }
  return out;
}

Eigen::Vector3d move_jacobian(const EdgeSample& m) {
  return {m.normal_box.x(), m.normal_box.y(),
          m.normal_box.dot(Eigen::Vector2d(-m.point_box.y(), m.point_box.x()))};
}

Move fit_move(const std::vector<EdgeSample>& moves, double correlated_m) {
  // n . (t + theta * perp(p)) = offset; a weak prior holds what no side constrains at 0.
  constexpr double kPrior = 0.5, kHuber_m = 0.003;
  Move out;
  Eigen::Matrix3d prior = kPrior * Eigen::Matrix3d::Identity();
  prior(2, 2) = kPrior * 0.04;  // a turn of 1 rad moves a side 0.2 m away by 0.2 m
  // Per axis of the box (sides 0-1 measure along its long side, 2-3 along its short side): the
  // samples' information, weighted squared residuals and weights.
  Eigen::Matrix3d axis_information[2];
  double weighted_sq[2] = {0.0, 0.0}, weights[2] = {0.0, 0.0};
  for (int iteration = 0; iteration < 4; ++iteration) {
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    axis_information[0] = axis_information[1] = Eigen::Matrix3d::Zero();
    weighted_sq[0] = weighted_sq[1] = weights[0] = weights[1] = 0.0;
    for (const EdgeSample& m : moves) {
      const Eigen::Vector3d J = move_jacobian(m);
      const double residual = J.dot(out.x) - m.offset_m;
      // Plain least squares first, then Huber weights around its answer: weights around no move
      // would discount every sample of a box that moved far and leave the prior holding it still.
      const double w = iteration == 0 || std::abs(residual) <= kHuber_m ? 1.0 : kHuber_m / std::abs(residual);
      const int axis = m.side / 2;
      axis_information[axis] += w * J * J.transpose();
      b += w * J * m.offset_m;
      weighted_sq[axis] += w * residual * residual;
      weights[axis] += w;
    }
    out.x = (prior + axis_information[0] + axis_information[1]).ldlt().solve(b);
  }
  // The samples' scatter, never taken below a millimetre (the grid's and the pixels' steps). A
  // rigid move shifts every side of one axis alike: where that axis's samples scatter more
  // than all of them do (a few lines that read steps tens of millimetres apart), its own scatter
  // says how well they place the box along it.
  const double pooled_sq =
      std::max(1e-6, (weighted_sq[0] + weighted_sq[1]) / std::max(1.0, weights[0] + weights[1] - 3.0));
  const double lines_per_sample = std::max(1.0, correlated_m / kSampleSpacing_m);
  out.information = prior + axis_information[0] + axis_information[1];
  const Eigen::Matrix3d inverse = out.information.inverse();
  Eigen::Matrix3d scatter = pooled_sq * prior;
  for (int axis = 0; axis < 2; ++axis)
    scatter +=
        std::max(pooled_sq, weighted_sq[axis] / std::max(1.0, weights[axis] - 1.0)) * axis_information[axis];
  out.covariance = lines_per_sample * inverse * scatter * inverse;
  return out;
}

}  // namespace palletd::pick_check
