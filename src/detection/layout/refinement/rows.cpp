// Rows of cartons larger than their format (rows.hpp).
#include "refinement/rows.hpp"

#include <algorithm>
#include <cmath>

namespace palletd::layout_detail {

void stretch_to_outline(const Rect& outline, double window_m, double max_oversize, std::vector<BoxEvidence>& ev) {
  constexpr double kGapShare = 0.03;  // gaps a row of cartons may stand with, beyond their growth
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300), hi = Eigen::Vector2d::Constant(-1e300);
  for (const BoxEvidence& e : ev) {
    lo = lo.cwiseMin(e.jb.center - e.jb.half);
    hi = hi.cwiseMax(e.jb.center + e.jb.half);
  }
  Eigen::Vector2d scale = Eigen::Vector2d::Ones(), offset = Eigen::Vector2d::Zero();
  const Eigen::Vector2d out_lo(outline.x0, outline.y0), out_hi(outline.x1, outline.y1);
  for (int a = 0; a < 2; ++a) {
    const double boxes_m = hi[a] - lo[a], outline_m = out_hi[a] - out_lo[a];
    if (!(boxes_m > 0.0) || outline_m - boxes_m < 0.5 * window_m ||
        outline_m > boxes_m * (1.0 + max_oversize + kGapShare))
      continue;
    scale[a] = outline_m / boxes_m;
    offset[a] = out_lo[a] - scale[a] * lo[a];
  }
  for (BoxEvidence& e : ev) e.jb.center = scale.cwiseProduct(e.jb.center) + offset;
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
