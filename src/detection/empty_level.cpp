// The top level before and around the layout: an empty pallet (below the region of interest, at
// the pallet's height, deck boards, a deck just above the floor, boxes over the slots between
// boards) and the layer's height above the pallet.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "level_checks.hpp"
#include "level_geometry.hpp"

namespace palletd {
namespace {

using level_detail::min_area_rect;
using level_detail::min_short_m;
using level_detail::mm;

/// Without box heights, a top level this close to the pallet's top is the pallet itself [m].
constexpr double kDeckBand_m = 0.05;
/// With box heights: within this share of the lowest box height of the pallet's top.
constexpr double kDeckBandBoxes = 0.4;
/// Deck boards: at least this many parallel strips narrower than this share of the smallest
/// box's short side, parallel within kBoardAngle_deg.
constexpr std::size_t kMinBoards = 3;
constexpr double kBoardWidthShare = 0.6;
constexpr double kBoardAngle_deg = 5.0;
/// Two boards merged into one strip: up to this many times a board's width, and as long as the
/// longest board within this share.
constexpr double kMergedBoards = 2.0;
constexpr double kBoardLengthShare = 0.1;
/// No carton layer on a pallet stands this little above the floor (a pallet is 0.14-0.16 m high,
/// a carton 0.1 m or more): the deck of an empty pallet [m].
constexpr double kMaxDeckAboveFloor_m = 0.2;
/// ... and at least this high: pallets stand 0.1 m and more. A lowest level in view closer below
/// the level is no floor under a deck: the level's own noise (a camera beyond its range), or a
/// view that holds no floor [m].
constexpr double kMinDeckAboveFloor_m = 0.08;
/// The floor: the lowest level below the layer holding at least this share of the sampled points.
constexpr double kMinFloorShare = 0.1;
/// A slot in the layer (a hole at least this many times longer than wide: the gap between two
/// deck boards) under this share of a box's top: no carton top has one.
constexpr double kSlotAspect = 4.0;
constexpr double kMaxSlotShare = 0.03;
/// The slot is looked for this far (or two pixel pitches) inside the box's sides [m].
constexpr double kSlotMargin_m = 0.025;

/// Mean of a piece's outer vertices (layer frame) [m].
Eigen::Vector2d piece_centre(const PolygonWithHoles& p) {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& v : p.outer) c += v;
  return p.outer.empty() ? c : Eigen::Vector2d(c / static_cast<double>(p.outer.size()));
}

/// Area centroid of the layer's polygons (layer frame) [m].
Eigen::Vector2d layer_centroid(const LayerResult& layer) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (const PolygonWithHoles& p : layer.polygons) {
    const double a = area(p);
    sum += a * piece_centre(p);
    total += a;
  }
  return total > 0.0 ? Eigen::Vector2d(sum / total) : Eigen::Vector2d::Zero();
}

/// The lowest known box height, 0 when no format has one [m].
double min_height_m(const std::vector<BoxFormat>& formats) {
  double h = 0.0;
  for (const BoxFormat& f : formats)
    if (f.height_m > 0.0) h = h > 0.0 ? std::min(h, f.height_m) : f.height_m;
  return h;
}

/// The level's pieces are parallel strips, kMinBoards or more of them narrower than any box's
/// top. A camera that smooths edges (stereo) may merge two neighbouring boards and the gap between
/// them into one strip: a strip up to twice as wide counts when it is as long as the boards.
bool deck_boards(const LayerResult& layer, const std::vector<BoxFormat>& formats) {
  if (layer.polygons.size() < kMinBoards || layer.diagnostics.touches_image_border) return false;
  const double max_width_mm = kBoardWidthShare * min_short_m(formats) * 1000.0;
  std::vector<double> angles_deg, merged_lengths_mm;
  double longest_board_mm = 0.0;
  std::size_t boards = 0;
  for (const PolygonWithHoles& p : layer.polygons) {
    if (p.outer.size() < 3) return false;
    const cv::RotatedRect r = min_area_rect(p.outer);
    const double width = std::min(r.size.width, r.size.height),
                 length = std::max(r.size.width, r.size.height);
    if (width > kMergedBoards * max_width_mm) return false;
    if (width > max_width_mm) {
      merged_lengths_mm.push_back(length);
    } else {
      ++boards;
      longest_board_mm = std::max(longest_board_mm, length);
    }
    // Direction of the strip's long side, modulo 180 degrees.
    double angle = r.angle + (r.size.width < r.size.height ? 90.0 : 0.0);
    angles_deg.push_back(std::fmod(angle + 360.0, 180.0));
  }
  if (boards < kMinBoards) return false;
  for (const double length : merged_lengths_mm) {
    if (std::abs(length - longest_board_mm) > kBoardLengthShare * longest_board_mm) return false;
  }
  for (const double a : angles_deg) {
    const double d = std::abs(a - angles_deg.front());
    if (std::min(d, 180.0 - d) > kBoardAngle_deg) return false;
  }
  return true;
}

/// The level's outline in mm, to tell the points of the layer plane inside it (not in a hole).
class LevelOutline {
 public:
  explicit LevelOutline(const LayerResult& layer) {
    for (const PolygonWithHoles& piece : layer.polygons) {
      if (piece.outer.size() < 3) continue;
      pieces_.push_back({level_detail::points_mm(piece.outer), {}});
      for (const Ring2d& hole : piece.holes)
        if (hole.size() >= 3) pieces_.back().holes.push_back(level_detail::points_mm(hole));
    }
  }
  /// q in the layer frame [m].
  [[nodiscard]] bool contains(const Eigen::Vector2d& q) const {
    const cv::Point2f q_mm(static_cast<float>(1e3 * q.x()), static_cast<float>(1e3 * q.y()));
    return std::any_of(pieces_.begin(), pieces_.end(), [&](const Piece& piece) {
      return cv::pointPolygonTest(piece.outer, q_mm, false) > 0 &&
             std::none_of(piece.holes.begin(), piece.holes.end(), [&](const std::vector<cv::Point2f>& hole) {
               return cv::pointPolygonTest(hole, q_mm, false) > 0;
             });
    });
  }

 private:
  struct Piece {
    std::vector<cv::Point2f> outer;
    std::vector<std::vector<cv::Point2f>> holes;
  };
  std::vector<Piece> pieces_;
};

/// A level whose outline runs along the region's sides, and along pixels the region left
/// without depth, for at least this share of its length goes on past the region: the region cut
/// it out of something larger. (A carton layer's edge beside a side of a tight region has a
/// lower level or the floor below the region beyond it, which keeps its depth.)
constexpr double kRegionCutShare = 0.5;
/// An outline edge lies along a side of the region when both its ends are this close to it [m].
constexpr double kRegionSide_m = 0.03;
/// The region's floor: a level this close above its bottom stands on nothing the region holds [m].
constexpr double kRegionFloorBand_m = 0.1;

/// The share of the level's outer outline that runs along the region's four sides (x and y in
/// the region's frame): where the points beyond were cut away, not where a carton ends.
double outline_share_on_region_sides(const LayerResult& layer, const RegionOfInterest& roi,
                                     const Eigen::Isometry3d& T_roi_camera) {
  auto side_of = [&](const Eigen::Vector3d& q) {
    int sides = 0;
    for (int axis = 0; axis < 2; ++axis) {
      if (std::abs(q[axis] - roi.min_m[axis]) < kRegionSide_m) sides |= 1 << (2 * axis);
      if (std::abs(q[axis] - roi.max_m[axis]) < kRegionSide_m) sides |= 2 << (2 * axis);
    }
    return sides;
  };
  double along_m = 0.0, total_m = 0.0;
  for (const PolygonWithHoles& piece : layer.polygons) {
    const Ring2d& ring = piece.outer;
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const Eigen::Vector2d& a = ring[i];
      const Eigen::Vector2d& b = ring[(i + 1) % ring.size()];
      const double length_m = (b - a).norm();
      total_m += length_m;
      const Eigen::Vector3d qa = T_roi_camera * (layer.T_camera_layer * Eigen::Vector3d(a.x(), a.y(), 0.0));
      const Eigen::Vector3d qb = T_roi_camera * (layer.T_camera_layer * Eigen::Vector3d(b.x(), b.y(), 0.0));
      if ((side_of(qa) & side_of(qb)) != 0) along_m += length_m;
    }
  }
  return total_m > 0.0 ? along_m / total_m : 0.0;
}

/// What the region of interest says of the level: nothing stands inside it when the level lies
/// below the region, or at the region's floor and cut by its sides (the cell's floor or a
/// station's surface without a load: a layer of cartons stands higher, inside the region).
std::optional<LevelVerdict> region_verdict(const Frame& frame, const LayerResult& layer,
                                           const RegionOfInterest& roi, const std::optional<double>& z_m) {
  const bool in_base = roi.frame == RegionOfInterest::Frame::kBase;
  if (in_base && !frame.T_base_camera) return std::nullopt;
  const Eigen::Vector2d centre = layer_centroid(layer);
  const Eigen::Vector3d centre_camera = layer.T_camera_layer * Eigen::Vector3d(centre.x(), centre.y(), 0.0);
  // Height above the region's bottom: base z up; in the camera frame the bottom is furthest.
  const double above_floor_m = in_base
                                   ? (z_m ? *z_m - roi.min_m.z() : std::numeric_limits<double>::infinity())
                                   : roi.max_m.z() - centre_camera.z();
  if (above_floor_m < 0.0)
    return LevelVerdict{DetectionStatus::kEmpty,
                        "nothing stands inside the region of interest: the top level lies below it"};
  if (above_floor_m >= kRegionFloorBand_m) return std::nullopt;
  const Eigen::Isometry3d T_roi_camera = in_base ? *frame.T_base_camera : Eigen::Isometry3d::Identity();
  const double cut = outline_share_on_region_sides(layer, roi, T_roi_camera);
  if (cut < kRegionCutShare || layer.diagnostics.unobserved_outline_fraction < kRegionCutShare)
    return std::nullopt;
  std::ostringstream share;
  share.precision(2);
  share << cut;
  return LevelVerdict{DetectionStatus::kEmpty,
                      "nothing stands inside the region of interest: the top level lies " +
                          mm(above_floor_m) + " above its bottom and goes on past its sides (" + share.str() +
                          " of its outline): the floor or the station, no load"};
}

}  // namespace

std::optional<double> layer_base_z_m(const LayerResult& layer,
                                     const std::optional<Eigen::Isometry3d>& T_base_camera) {
  if (!T_base_camera || layer.polygons.empty()) return std::nullopt;
  const Eigen::Vector2d c = layer_centroid(layer);
  const Eigen::Vector3d p_camera = layer.T_camera_layer * Eigen::Vector3d(c.x(), c.y(), 0.0);
  return (*T_base_camera * p_camera).z();
}

std::optional<LevelVerdict> empty_level(const Frame& frame, const LayerResult& layer,
                                        const std::vector<BoxFormat>& formats,
                                        const DetectionParams& params) {
  const std::optional<double> z_m = layer_base_z_m(layer, frame.T_base_camera);
  if (params.roi)
    if (std::optional<LevelVerdict> verdict = region_verdict(frame, layer, *params.roi, z_m)) return verdict;
  if (params.pallet.top_z_m && z_m) {
    const double h_box = min_height_m(formats);
    const double band = h_box > 0.0 ? kDeckBandBoxes * h_box : kDeckBand_m;
    const double above = *z_m - *params.pallet.top_z_m;
    if (above < band)
      return LevelVerdict{DetectionStatus::kEmpty,
                          "the top level is the pallet's deck (" + mm(above) + " above pallet.top_z_m)"};
    return std::nullopt;  // the pallet's height decides
  }
  if (deck_boards(layer, formats))
    return LevelVerdict{DetectionStatus::kEmpty,
                        "the top level is " + std::to_string(layer.polygons.size()) +
                            " parallel strips of a pallet's deck (boards narrower than any box)"};
  return std::nullopt;
}

std::optional<LevelVerdict> deck_above_floor(const OrganizedCloud& cloud, const LayerResult& layer,
                                             const PlaneParams& validity,
                                             const std::optional<Eigen::Isometry3d>& T_base_camera) {
  // Heights below the top level of about 10^4 sampled points, in 1 cm bins: along the base's up
  // axis when the calibration gives it (below_m = a . p + b), measured from the highest piece of
  // the level, else from the layer's plane. A noisy camera far away may take a strip of floor
  // into the level of a deck or a sheet, and the plane fitted across both tilts the floor into a
  // slope; the highest piece is the deck or the sheet, not the strip.
  Eigen::Vector3d a = -layer.plane_camera.normal;
  double b_m = -layer.plane_camera.d;
  if (T_base_camera) {
    const Eigen::Vector3d up = T_base_camera->linear().row(2).transpose();
    a = -up;
    b_m = -std::numeric_limits<double>::max();
    for (const PolygonWithHoles& piece : layer.polygons) {
      if (piece.outer.empty()) continue;
      const Eigen::Vector2d c = piece_centre(piece);
      b_m = std::max(b_m, up.dot(layer.T_camera_layer * Eigen::Vector3d(c.x(), c.y(), 0.0)));
    }
    if (layer.polygons.empty()) return std::nullopt;
  }
  constexpr double kBin_m = 0.01;
  constexpr int kBins = 400;  // down to 4 m
  std::vector<int> bins(kBins, 0);
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(cloud.points.size()) / 1e4)));
  // The floor shows around the level or through its holes (a deck's slots), never inside its
  // outline: there a noisy camera spreads the level's own points below it.
  const Eigen::Isometry3d T_layer_camera = layer.T_camera_layer.inverse();
  const LevelOutline level(layer);
  std::size_t sampled = 0;
  for (int v = 0; v < cloud.height; v += step) {
    for (int u = 0; u < cloud.width; u += step) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!p.allFinite() || p.z() < validity.min_depth_m || p.z() > validity.max_depth_m) continue;
      ++sampled;
      const Eigen::Vector3d q = T_layer_camera * p.cast<double>();
      if (level.contains(q.head<2>())) continue;
      const double below_m = a.dot(p.cast<double>()) + b_m;
      const int b = static_cast<int>(below_m / kBin_m);
      if (below_m > 0.0 && b < kBins) ++bins[static_cast<std::size_t>(b)];
    }
  }
  const auto floor_count = static_cast<int>(kMinFloorShare * static_cast<double>(sampled));
  for (int b = kBins - 2; b >= 0; --b) {
    if (bins[static_cast<std::size_t>(b)] + bins[static_cast<std::size_t>(b) + 1] < std::max(floor_count, 50))
      continue;
    const double floor_below_m = (b + 1) * kBin_m;  // the floor: the lowest level with enough points
    if (floor_below_m >= kMaxDeckAboveFloor_m || floor_below_m < kMinDeckAboveFloor_m) return std::nullopt;
    return LevelVerdict{DetectionStatus::kEmpty,
                        "the top level stands " + mm(floor_below_m) +
                            " above the floor and no box of the recipe fits it: an empty pallet's deck"};
  }
  return std::nullopt;
}

std::optional<LevelVerdict> boxes_over_slots(const LayoutResult& layout, const LayerResult& layer) {
  for (const PolygonWithHoles& polygon : layer.polygons) {
    for (const Ring2d& hole : polygon.holes) {
      if (hole.size() < 3) continue;
      const cv::RotatedRect r = min_area_rect(hole);
      const double w = std::min(r.size.width, r.size.height), l = std::max(r.size.width, r.size.height);
      if (!(w > 0.0) || l < kSlotAspect * w) continue;
      for (std::size_t i = 0; i < layout.boxes.size(); ++i) {
        const LayoutBox& b = layout.boxes[i];
        if (b.partly_unseen) continue;
        // The hole in the box's own frame, clipped by the box's top.
        const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
        PolygonWithHoles local;
        for (const Eigen::Vector2d& v : hole) {
          const Eigen::Vector2d d = v - b.center;
          local.outer.emplace_back(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
        }
        if (signed_area(local.outer) < 0.0) std::reverse(local.outer.begin(), local.outer.end());
        // Only the box's inner part: a hole beside the box (a chimney, a pinwheel's centre) that
        // its side reaches into by a pixel or two is no slot through its top.
        const double margin_m = std::max(kSlotMargin_m, 2.0 * layout.pixel_pitch_m);
        const double hx = 0.5 * b.long_m - margin_m, hy = 0.5 * b.short_m - margin_m;
        if (hx <= 0.0 || hy <= 0.0) continue;
        const double over = clipped_area(local, -hx, -hy, hx, hy);
        if (over > kMaxSlotShare * b.long_m * b.short_m)
          return LevelVerdict{DetectionStatus::kOk, "box " + std::to_string(i) +
                                                        " lies over a slot in the layer (" + mm(l * 1e-3) +
                                                        " by " + mm(w * 1e-3) +
                                                        "): no carton top has one (a pallet's deck boards?)"};
      }
    }
  }
  return std::nullopt;
}

void layer_height(const std::optional<double>& layer_z_m, const std::vector<BoxFormat>& formats,
                  const PalletParams& pallet, Detection& out) {
  if (!layer_z_m || !pallet.top_z_m) return;
  const double h = *layer_z_m - *pallet.top_z_m;
  out.height_above_pallet_m = h;
  if (out.status == DetectionStatus::kEmpty) {
    out.layers_remaining = 0;
    return;
  }
  if (out.boxes.empty()) return;
  double sum = 0.0;
  for (const DetectedBox& b : out.boxes) {
    const std::size_t f = static_cast<std::size_t>(std::max(0, b.format));
    if (f >= formats.size() || !(formats[f].height_m > 0.0)) return;  // a height unknown
    sum += formats[f].height_m;
  }
  const double box_m = sum / static_cast<double>(out.boxes.size());
  const double layers = h / box_m;
  const double whole = std::max(1.0, std::round(layers));
  out.layers_remaining = static_cast<int>(whole);
  if (std::abs(layers - whole) > pallet.height_tolerance) {
    std::ostringstream s;
    s.precision(3);
    s << "the layer stands " << mm(h) << " above the pallet, " << layers << " box heights of " << mm(box_m)
      << ": not a whole number of layers (a missing or extra layer, other boxes than the recipe's)";
    out.ambiguous = true;
    out.height_off_layers = true;
    out.ambiguity_reason += (out.ambiguity_reason.empty() ? "" : "; ") + s.str();
    out.ambiguity_kinds.push_back(AmbiguityKind::kHeightOffLayers);
  }
}

}  // namespace palletd
