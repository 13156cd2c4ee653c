// Side samples for the refinement (private to the layout stage): where one side of a box lies
// along its stretch, from the box's own layer points (an outline side, with the rim's mixed
// pixels) or from the seam raster (a side shared with a neighbour). Values in the component's
// layout frame.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "layout_internal.hpp"
#include "palletd/detection/layout.hpp"
#include "refinement/refine_joint.hpp"

namespace palletd::layout_detail {

/// One side of a box in its component's layout frame.
struct SideRef {
  double pos = 0;          ///< current side position along `axis` [m]
  double lo = 0, hi = 0;   ///< measured stretch along the side [m]
  double t_ref = 0;        ///< box centre along the side [m]
  int axis = 0, sign = 1;
};

/// The side of `b` along `axis` on the `sign` side, its stretch shortened by margin_m at each end.
SideRef side_of(const JointBox& b, int axis, int sign, double margin_m);

/// Outline side: per slice along the side, walk the box's own layer points outward from inside
/// the box and stop at the first gap (no points over 2.5 footprints); the edge is the last point
/// plus half a pixel, plus `shift` (the footprint correction). Where `rim` holds mixed pixels
/// just beyond that last point (x, y in the frame, top share), the edge lies within their
/// footprint by their top share instead (no correction: the share measures it). The edge may lie
/// up to window_m beyond the current side (points are read a gap further to see it end). Samples
/// (t, p) in the frame.
std::vector<Eigen::Vector2d> outline_samples(const SideRef& s, const std::vector<Eigen::Vector2d>& local,
                                             const std::vector<Eigen::Vector3d>* rim, double pitch_m,
                                             double window_m, double window_in_m, double shift);

/// Shared side: per slice, walk the seam raster outward from inside the box to where it first
/// reaches 0.5 (the box's own edge of the seam band; sub-cell by linear interpolation).
std::vector<Eigen::Vector2d> seam_samples(const SideRef& s, const SeamEvidence& ev, const LayoutFrame& frame,
                                          double window_m, double window_in_m);

}  // namespace palletd::layout_detail
