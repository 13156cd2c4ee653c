// Private to the layout stage: how well one box is supported by the measurements.
#pragma once

#include "layout_internal.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd::layout_detail {

struct BoxSupport {
  double inside_area_m2 = 0.0;    ///< Area(box ∩ component)
  double inside_fraction = 0.0;   ///< of the box area
  double interior_seam = 0.0;     ///< strongest seam line crossing the interior, 0..1
  double edge_seam = 1.0;         ///< mean seam support of the edges shared with neighbours, 0..1
  int shared_edges = 0;           ///< 1 when some edge has layer beyond it
  double score = 0.0;             ///< 0..1
};

/// Copies the support terms into a box's evidence.
inline void set_support_terms(const BoxSupport& s, BoxEvidence& e) {
  e.inside = s.inside_fraction;
  e.interior_seam = s.interior_seam;
  e.edge_seams = s.edge_seam;
  e.shared_sides = s.shared_edges > 0;
}

BoxSupport box_support(const Box2d& box, const PolygonWithHoles& component,
                       const SeamEvidence* seams, const LayoutParams& params);

/// The same with a layout frame's seam table (null = outline only) and the component in that
/// frame; the box must be turned by 0 or 90 deg against the frame.
BoxSupport box_support(const Box2d& box, const LayoutFrame& frame, const PolygonWithHoles& frame_polygon,
                       const SeamTable* table, const LayoutParams& params);

/// The strongest seam column across the box's long axis within reach_m of its middle, 0..1: the
/// line along which the box would be two boxes of half its length.
double seam_across_middle(const Box2d& box, const SeamEvidence* seams, const LayoutParams& params,
                          double reach_m);

/// Largest connected piece of the component (layout frame) that no box covers, the gaps between
/// boxes left out (pieces narrower than gap_m vanish) [m^2].
double largest_uncovered_m2(const PolygonWithHoles& frame_polygon, const std::vector<FrameBox>& boxes, double gap_m);

}  // namespace palletd::layout_detail
