// Rows of cartons larger than their format (rows.hpp).
#include "refinement/rows.hpp"

#include <algorithm>
#include <cmath>

namespace palletd::layout_detail {

Stretch stretch_to_outline(const std::vector<std::size_t>& idx, const std::vector<LayoutBox>& boxes,
                           const ComponentFit& cf, const RefineContext& ctx) {
  constexpr double kGapShare = 0.03;  // gaps a row of cartons may stand with, beyond their growth
  Stretch st;
  const Rect outline = bounds_of(cf.polygon);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300), hi = Eigen::Vector2d::Constant(-1e300);
  for (std::size_t i : idx) {
    const Box2d& box = boxes[i];
    const Eigen::Vector2d c = cf.frame.to_frame(box.center);
    const bool along_x = std::abs(std::remainder(box.yaw_rad - cf.frame.theta_rad, M_PI)) < M_PI / 4;
    const Eigen::Vector2d half = along_x ? Eigen::Vector2d(box.long_m / 2, box.short_m / 2)
                                         : Eigen::Vector2d(box.short_m / 2, box.long_m / 2);
    lo = lo.cwiseMin(c - half);
    hi = hi.cwiseMax(c + half);
  }
  const Eigen::Vector2d out_lo(outline.x0, outline.y0), out_hi(outline.x1, outline.y1);
  for (int a = 0; a < 2; ++a) {
    const double boxes_m = hi[a] - lo[a], outline_m = out_hi[a] - out_lo[a];
    if (!(boxes_m > 0.0) || outline_m - boxes_m < 0.5 * ctx.window_m ||
        outline_m > boxes_m * (1.0 + ctx.params.refine.max_oversize + kGapShare))
      continue;
    st.scale[a] = outline_m / boxes_m;
    st.offset[a] = out_lo[a] - st.scale[a] * lo[a];
  }
  return st;
}

std::vector<Contact> filled_gaps(const std::vector<BoxEvidence>& ev, const std::vector<JointBox>& fitted,
                                 const std::vector<Contact>& contacts, double margin_m, double reach_m) {
  constexpr double kFilledShare = 0.6;  // of the pixels the gap would hold: a top, not a few stray points
  std::vector<Contact> out;
  for (std::size_t a = 0; a < fitted.size(); ++a) {
    for (std::size_t b = 0; b < fitted.size(); ++b) {
      for (int ax = 0; ax < 2 && a != b; ++ax) {
        const bool touching = std::any_of(contacts.begin(), contacts.end(), [&](const Contact& t) {
          return t.a == static_cast<int>(a) && t.b == static_cast<int>(b) && t.axis == ax;
        });
        const int o = 1 - ax;
        const double pitch = std::max(ev[a].pitch_m, ev[b].pitch_m);
        const double side_a = fitted[a].center[ax] + fitted[a].half[ax];
        const double g0 = side_a + 0.5 * pitch, g1 = fitted[b].center[ax] - fitted[b].half[ax] - 0.5 * pitch;
        const double t0 =
            std::max(fitted[a].center[o] - fitted[a].half[o], fitted[b].center[o] - fitted[b].half[o]) +
            margin_m;
        const double t1 =
            std::min(fitted[a].center[o] + fitted[a].half[o], fitted[b].center[o] + fitted[b].half[o]) -
            margin_m;
        if (touching || g1 - g0 < pitch || t1 - t0 < 4 * pitch || g1 > side_a + reach_m) continue;
        std::size_t in = 0;
        for (const Eigen::Vector2d& q : ev[a].points)
          if (q[ax] > g0 && q[ax] < g1 && q[o] > t0 && q[o] < t1) ++in;
        const double expected = (g1 - g0) * (t1 - t0) / (pitch * pitch);
        if (static_cast<double>(in) >= kFilledShare * expected)
          out.push_back({static_cast<int>(a), static_cast<int>(b), ax, 0.5 * pitch});
      }
    }
  }
  return out;
}

}  // namespace palletd::layout_detail
