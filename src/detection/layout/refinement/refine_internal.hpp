// Private to the layout stage: the phases of refine_layout (refine.cpp) on one component
// (refine_component.cpp): its frame, each box's local evidence, each side measured, the joint fit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "layout_internal.hpp"
#include "refinement/refine_joint.hpp"

namespace palletd::layout_detail {

/// Layer points binned in a coarse grid so that each box only visits its neighbourhood.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector2f>& pts, double cell_m);
  /// Calls f(point) for every point in the cells the rectangle touches.
  template <typename F>
  void visit(double x0, double y0, double x1, double y1, F&& f) const {
    if (bins_.empty()) return;
    const int c0 = column(x0), c1 = column(x1), r0 = row(y0), r1 = row(y1);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        for (auto i : bins_[index(r, c)]) f(pts_[i]);
      }
    }
  }

 private:
  [[nodiscard]] int column(double x) const;
  [[nodiscard]] int row(double y) const;
  [[nodiscard]] std::size_t index(int r, int c) const {
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(c);
  }
  const std::vector<Eigen::Vector2f>& pts_;
  double cell_;
  double x0_ = 0, y0_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<std::vector<std::uint32_t>> bins_;
};

/// What every component's refinement shares.
struct RefineContext {
  const LayerResult& layer;
  const std::vector<BoxFormat>& formats;
  const LayoutParams& params;
  const SeamEvidence* seams = nullptr;  ///< null when there is no usable seam evidence
  const LayerSurroundings* surroundings = nullptr;
  const std::vector<RimPixel>* rim = nullptr;
  const PointGrid& grid;  ///< the layer points
  double pitch_m = 0.0;   ///< mean pixel pitch on the layer
  double window_m = 0.0;  ///< how far beyond where the search put it a side may lie
  double window_in_m = 0.0;  ///< how far inside it (a box's size is at most a little under nominal)
  Eigen::Vector3d camera_layer = Eigen::Vector3d::Zero();  ///< the camera in the layer frame
  bool view_known = false;  ///< the camera is above the plane (footprint corrections apply)
};

/// A box's evidence in the component frame (refine_component.cpp gathers it).
struct BoxEvidence {
  JointBox jb;
  bool along_x = true;                  ///< its long side along the frame's x
  double pitch_m = 0.0;                 ///< pixel pitch on its top
  std::vector<Eigen::Vector2d> points;  ///< layer points around it
  std::vector<Eigen::Vector3d> rim;     ///< rim pixels around it: (x, y) in the frame, top share
};

/// A component's refinement: its layout frame and measured turn.
struct ComponentFit {
  bool built = false;
  LayoutFrame frame;
  PolygonWithHoles polygon;  ///< the component in the frame
  SeamTable table;
  double turn_rad = 0.0;     ///< measured orientation: the frame's plus the common side turn
  double turn_weight = 0.0;  ///< 1 / variance of that measurement (sum of side weights)
};

/// Fits the boxes `idx` of component `polygon` jointly and writes their centres and sizes into
/// `boxes`; `box_turn[i]` receives each refined box's own turn against its component (left
/// unchanged where the fit is rejected). `w_prior` = 1 / (RefineParams::yaw_sigma_deg)^2 [rad^-2].
ComponentFit fit_component(const std::vector<std::size_t>& idx, const PolygonWithHoles& polygon,
                           const RefineContext& ctx, double w_prior, std::vector<LayoutBox>& boxes,
                           std::vector<double>& box_turn);

}  // namespace palletd::layout_detail
