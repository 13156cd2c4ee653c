// The next level of the load beside the top level (see level_checks.hpp: lower_level_beside).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "level_checks.hpp"
#include "level_geometry.hpp"

namespace palletd {

namespace {

constexpr double kMinBesideCell_m = 0.01;  ///< the raster around the level, at least a pixel pitch [m]
/// Points this close outside the outline are left out: the stack's sides under the layer's edge,
/// a bulge or a lower layer that sticks out, and the mixed pixels along the edge [m].
constexpr double kBesideFrom_m = 0.06;
/// A level of cartons lies at least this far below the top (a carton's height) and at most this
/// far (a layer of the tallest cartons); the floor further down is left out on its own [m].
constexpr double kBesideMinDrop_m = 0.08;
constexpr double kBesideMaxDrop_m = 0.8;
/// A level is flat: its points lie within this of its height [m].
constexpr double kBesideBand_m = 0.015;
constexpr double kDropBin_m = 0.01;
constexpr int kDropBins = 400;  ///< drops binned down to 4 m
/// The floor: the deepest level holding at least this share of the points around the top level
/// (or the pallet's deck where its height is known); a level this close above it is the floor
/// or stands on it, not the load [m].
constexpr double kFloorShare = 0.1;
constexpr double kBesideAboveFloor_m = 0.05;
/// The floor's points are looked at this many bins either side of it (its noise).
constexpr int kFloorSpreadBins = 10;
constexpr std::size_t kBesideSamples = 100000;

/// The layer's outer rings filled (holes are part of the level's footprint here: a chimney's
/// floor is no level beside it), and each cell's distance to them [cells].
struct Footprint {
  Eigen::Vector2d origin_m;
  double cell_m;
  int width = 0, height = 0;
  cv::Mat distance;  ///< CV_32F, 0 inside

  Footprint(const LayerResult& layer, double reach_m, double cell) : cell_m(cell) {
    Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
    for (const PolygonWithHoles& p : layer.polygons) {
      for (const Eigen::Vector2d& v : p.outer) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
    }
    if (lo.x() > hi.x()) return;
    origin_m = lo - Eigen::Vector2d::Constant(reach_m + cell_m);
    width = static_cast<int>(std::ceil((hi.x() - lo.x() + 2.0 * (reach_m + cell_m)) / cell_m));
    height = static_cast<int>(std::ceil((hi.y() - lo.y() + 2.0 * (reach_m + cell_m)) / cell_m));
    cv::Mat outside(height, width, CV_8U, cv::Scalar(1));
    std::vector<std::vector<cv::Point>> rings;
    for (const PolygonWithHoles& p : layer.polygons) {
      std::vector<cv::Point> ring;
      for (const Eigen::Vector2d& v : p.outer) ring.push_back(cell_of(v));
      if (ring.size() >= 3) rings.push_back(std::move(ring));
    }
    cv::fillPoly(outside, rings, cv::Scalar(0));
    cv::distanceTransform(outside, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  }
  [[nodiscard]] cv::Point cell_of(const Eigen::Vector2d& q) const {
    return {static_cast<int>(std::floor((q.x() - origin_m.x()) / cell_m)),
            static_cast<int>(std::floor((q.y() - origin_m.y()) / cell_m))};
  }
  /// The cell's distance outside the outline [m], negative off the raster.
  [[nodiscard]] double outside_m(const cv::Point& c) const {
    if (c.x < 0 || c.y < 0 || c.x >= width || c.y >= height) return -1.0;
    return cell_m * distance.at<float>(c.y, c.x);
  }
};

/// A point around the top level within reach, and how far below the layer's plane it lies.
struct Beside {
  int cell;
  double drop_m;
};

/// The floor: the deepest level with kFloorShare of the points, its drop where its points are
/// densest; how far above that the floor's noise reaches (kBesideAboveFloor_m at least, three
/// sigma of its points). Infinity without one [m].
double floor_reach_m(const std::vector<int>& bins, std::size_t sampled) {
  const auto need = static_cast<int>(kFloorShare * static_cast<double>(sampled));
  int deep = -1;
  for (int b = kDropBins - 2; b >= 0 && deep < 0; --b)
    if (bins[static_cast<std::size_t>(b)] + bins[static_cast<std::size_t>(b) + 1] >= std::max(need, 50))
      deep = b + 1;
  if (deep < 0) return std::numeric_limits<double>::infinity();
  const int lo = std::max(0, deep - kFloorSpreadBins), hi = std::min(kDropBins - 1, deep + 1);
  int mode = deep;
  for (int b = lo; b <= hi; ++b)
    if (bins[static_cast<std::size_t>(b)] > bins[static_cast<std::size_t>(mode)]) mode = b;
  double n = 0.0, sum = 0.0, sum2 = 0.0;
  for (int b = std::max(0, mode - kFloorSpreadBins); b <= std::min(kDropBins - 1, mode + kFloorSpreadBins);
       ++b) {
    const double c = bins[static_cast<std::size_t>(b)], x = (b + 0.5) * kDropBin_m;
    n += c;
    sum += c * x;
    sum2 += c * x * x;
  }
  const double mean = sum / n, sigma = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  return (mode + 0.5) * kDropBin_m - std::max(kBesideAboveFloor_m, 3.0 * sigma);
}

}  // namespace

std::optional<LevelBeside> lower_level_beside(const OrganizedCloud& cloud, const LayerResult& layer,
                                              const std::vector<BoxFormat>& formats,
                                              const PlaneParams& validity, double pixel_pitch_m,
                                              std::optional<double> above_deck_m) {
  if (layer.polygons.empty() || formats.empty() || cloud.points.empty()) return std::nullopt;
  // Far enough out for a row of the next level beyond the top's edge, part of it hidden behind
  // that edge from a tilted camera.
  double reach_m = 0.0;
  for (const BoxFormat& f : formats) reach_m = std::max(reach_m, f.short_m);
  reach_m = std::max(reach_m, 0.25);
  const Footprint footprint(layer, reach_m, std::max(kMinBesideCell_m, pixel_pitch_m));
  if (footprint.width <= 0) return std::nullopt;
  const Eigen::Isometry3d T_layer_camera = layer.T_camera_layer.inverse();
  // The camera looks down on the level: below is away from it.
  const double down = T_layer_camera.translation().z() > 0.0 ? -1.0 : 1.0;
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(cloud.points.size()) /
                                                          static_cast<double>(kBesideSamples))));
  std::vector<int> bins(kDropBins, 0), near_bins(kDropBins, 0);
  std::vector<Beside> near;
  std::size_t sampled = 0;
  for (int v = 0; v < cloud.height; v += step) {
    for (int u = 0; u < cloud.width; u += step) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!p.allFinite() || p.z() < validity.min_depth_m || p.z() > validity.max_depth_m) continue;
      const Eigen::Vector3d q = T_layer_camera * p.cast<double>();
      const double drop_m = down * q.z();
      const cv::Point c = footprint.cell_of(q.head<2>());
      const double out_m = footprint.outside_m(c);
      if (out_m == 0.0) continue;  // on the top level's footprint
      ++sampled;
      const int b = static_cast<int>(drop_m / kDropBin_m);
      if (drop_m > 0.0 && b < kDropBins) ++bins[static_cast<std::size_t>(b)];
      if (out_m < kBesideFrom_m || out_m > reach_m || drop_m < kBesideMinDrop_m || drop_m > kBesideMaxDrop_m)
        continue;
      near.push_back({c.y * footprint.width + c.x, drop_m});
      ++near_bins[static_cast<std::size_t>(b)];
    }
  }
  if (near.empty()) return std::nullopt;
  // Levels from here down are the floor or stand on the pallet's deck, not on the load.
  double floor_m = floor_reach_m(bins, sampled);
  if (above_deck_m) floor_m = std::min(floor_m, *above_deck_m - kBesideAboveFloor_m);
  // The most populated height beside the level, above the floor, and the area its points cover.
  int peak = -1;
  for (int b = 0; b + 1 < kDropBins; ++b) {
    if ((b + 1) * kDropBin_m > floor_m) break;
    if (peak < 0 || near_bins[static_cast<std::size_t>(b)] > near_bins[static_cast<std::size_t>(peak)])
      peak = b;
  }
  if (peak < 0) return std::nullopt;
  const double level_m = (peak + 0.5) * kDropBin_m;
  std::vector<std::uint8_t> covered(static_cast<std::size_t>(footprint.width) * footprint.height, 0);
  std::size_t cells = 0, points = 0;
  double drop_sum_m = 0.0;
  for (const Beside& s : near) {
    if (std::abs(s.drop_m - level_m) > kBesideBand_m) continue;
    std::uint8_t& c = covered[static_cast<std::size_t>(s.cell)];
    cells += c == 0 ? 1 : 0;
    c = 1;
    ++points;
    drop_sum_m += s.drop_m;
  }
  const double area_m2 = static_cast<double>(cells) * footprint.cell_m * footprint.cell_m;
  if (area_m2 < level_detail::min_area_m2(formats)) return std::nullopt;
  return LevelBeside{drop_sum_m / static_cast<double>(points), area_m2};
}

LevelVerdict rest_of_a_layer(const LevelBeside& beside, const LayoutResult& layout) {
  std::ostringstream s;
  s.precision(2);
  s << "no seam is seen between the boxes (" << layout.interior_seams.seen_share()
    << " of their shared sides), but the load's next level shows beside the layer ("
    << level_detail::mm(beside.drop_m) << " lower, " << beside.area_m2
    << " m2 of it): a slip sheet lies over a whole layer, so these are more likely cartons pressed "
       "together; a sheet cannot be ruled out";
  return LevelVerdict{DetectionStatus::kOk, s.str()};
}

}  // namespace palletd
