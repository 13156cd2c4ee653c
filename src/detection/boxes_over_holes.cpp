// A box whose top, seen in depth, falls away: the layout put a carton where the depth shows a
// hole (a chimney, the place of a carton already picked) that the outline lost, e.g. where the
// hole reaches a gap between cartons through a channel narrower than the crust's pruning length.
// Each pixel is read where its ray crosses the layer's plane: a pixel whose ray meets the plane
// inside a box's top must see that top, and one that sees deeper looked through it. (A point
// straight below a box's top may be seen from the side, under a carton that overhangs the level
// below it.)
#include <cmath>
#include <vector>

#include "level_checks.hpp"
#include "level_geometry.hpp"

namespace palletd {
namespace {

/// Depth this far below the layer's plane is no carton top: a top bulges or sags by a few
/// millimetres, the next level down lies a carton's height (0.1 m or more) lower [m].
constexpr double kBelowLayer_m = 0.04;
/// The box's top is read this far (or two pixel pitches) inside its sides, clear of the seams,
/// gaps and mixed pixels along them [m].
constexpr double kInset_m = 0.025;
/// A box falls away over at least this share of the depth samples inside it, and this many.
constexpr double kMinHoleShare = 0.1;
constexpr std::size_t kMinHoleSamples = 8;
/// About this many points of the cloud are read.
constexpr double kSampledPoints = 2e4;

struct TopSamples {
  std::size_t seen = 0, below = 0;
};

/// A box's top in the layer frame, inset: centre, axes and half extents.
struct InsetTop {
  Eigen::Vector2d center, along;
  double half_long_m = 0.0, half_short_m = 0.0;
};

/// Index of the inset top that holds the layer-frame point, or -1.
int top_at(const std::vector<InsetTop>& tops, const Eigen::Vector2d& q) {
  for (std::size_t i = 0; i < tops.size(); ++i) {
    const InsetTop& t = tops[i];
    const Eigen::Vector2d d = q - t.center;
    if (std::abs(t.along.dot(d)) <= t.half_long_m &&
        std::abs(t.along.x() * d.y() - t.along.y() * d.x()) <= t.half_short_m)
      return static_cast<int>(i);
  }
  return -1;
}

}  // namespace

std::optional<LevelVerdict> boxes_over_holes(const OrganizedCloud& cloud, const LayoutResult& layout,
                                             const LayerResult& layer) {
  if (layout.boxes.empty() || cloud.points.empty()) return std::nullopt;
  const double inset_m = std::max(kInset_m, 2.0 * layout.pixel_pitch_m);
  const Eigen::Isometry3d T_layer_camera = layer.T_camera_layer.inverse();
  const Plane& plane = layer.plane_camera;
  std::vector<InsetTop> inset;
  for (const LayoutBox& b : layout.boxes)
    inset.push_back({b.center, Eigen::Vector2d(std::cos(b.yaw_rad), std::sin(b.yaw_rad)),
                     0.5 * b.long_m - inset_m, 0.5 * b.short_m - inset_m});
  std::vector<TopSamples> tops(layout.boxes.size());
  const auto step = static_cast<std::size_t>(
      std::max(1.0, std::floor(std::sqrt(static_cast<double>(cloud.points.size()) / kSampledPoints))));
  for (std::size_t v = 0; v < static_cast<std::size_t>(cloud.height); v += step) {
    for (std::size_t u = 0; u < static_cast<std::size_t>(cloud.width); u += step) {
      const Eigen::Vector3d p = cloud.points[v * static_cast<std::size_t>(cloud.width) + u].cast<double>();
      const double n_dot_p = plane.normal.dot(p);
      if (!p.allFinite() || std::abs(n_dot_p) < 1e-9) continue;
      const Eigen::Vector3d crossing = p * (-plane.d / n_dot_p);  // the ray from the camera meets the plane
      const int i = top_at(inset, (T_layer_camera * crossing).head<2>());
      if (i < 0) continue;
      ++tops[static_cast<std::size_t>(i)].seen;
      if (-plane.signed_distance(p) > kBelowLayer_m) ++tops[static_cast<std::size_t>(i)].below;
    }
  }
  std::size_t over = 0, worst = 0;
  double worst_share = 0.0;
  for (std::size_t i = 0; i < tops.size(); ++i) {
    const TopSamples& t = tops[i];
    const double share = t.seen > 0 ? static_cast<double>(t.below) / static_cast<double>(t.seen) : 0.0;
    if (t.below < kMinHoleSamples || share < kMinHoleShare) continue;
    ++over;
    if (share > worst_share) worst_share = share, worst = i;
  }
  if (over == 0) return std::nullopt;
  return LevelVerdict{DetectionStatus::kOk,
                      std::to_string(over) +
                          " box(es) stand over a hole: the depth seen through the top of box " +
                          std::to_string(worst) + " lies more than " + level_detail::mm(kBelowLayer_m) +
                          " below the layer over " + std::to_string(static_cast<int>(100.0 * worst_share)) +
                          " % of it (a chimney or a carton already picked, which the outline lost)"};
}

}  // namespace palletd
