#include "level_checks.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

namespace palletd {
namespace {

/// Without box heights, a top level this close to the pallet's top is the pallet itself [m].
constexpr double kDeckBand_m = 0.05;
/// With box heights: within this share of the lowest box height of the pallet's top.
constexpr double kDeckBandBoxes = 0.4;
/// Deck boards: at least this many parallel strips, each narrower than this share of the
/// smallest box's short side, parallel within kBoardAngle_deg.
constexpr std::size_t kMinBoards = 3;
constexpr double kBoardWidthShare = 0.6;
constexpr double kBoardAngle_deg = 5.0;
/// A layout is "seamless" when its interior sides show a seam along less than this share.
constexpr double kSeamlessShare = 0.1;
/// The groove between two cartons (their rounded top edges, 3 mm radius and more, plus the gap)
/// is at least this wide: a sensor whose pixel pitch on the layer is finer resolves it [m].
constexpr double kResolvableSeam_m = 0.006;
/// The layer is one rectangle when it fills at least this share of its minimum-area rectangle.
constexpr double kRectangleFill = 0.95;
/// A hole in a layer's outline smaller than a square of this side is depth that dropped out on a
/// top (a glint, dark print, tape), not a place where a carton stands lower or is missing: the
/// smallest chimney of a pinwheel is the difference of a carton's sides, 80 mm and more [m].
constexpr double kDropoutHole_m = 0.04;
/// A box whose own two opposite sides measure it shorter than its format by more than this many
/// pixel pitches (and more than the refinement's size tolerance) is not that format: cartons are
/// built at or over their format, and a side is placed to about a pixel.
constexpr double kUndersize_px = 2.0;
/// A sheet covers a whole layer: a tiling of at least this many boxes (a stepped remainder of one
/// to three cartons is no sheet).
constexpr std::size_t kMinSheetBoxes = 4;
/// A seam line across a box (or between two boxes) at least this strong tells one box from two.
constexpr double kSplitSeam = 0.5;
/// The rim shows mixed pixels along at least this share of the outline: the camera mixes depths
/// across an edge, so a seam narrower than a pixel still shows as a dip.
constexpr double kMixingRimShare = 0.3;
/// No carton layer on a pallet stands this little above the floor (a pallet is 0.14-0.16 m high,
/// a carton 0.1 m or more): the deck of an empty pallet [m].
constexpr double kMaxDeckAboveFloor_m = 0.2;
/// The floor: the lowest level below the layer holding at least this share of the sampled points.
constexpr double kMinFloorShare = 0.1;
/// A slot in the layer (a hole at least this many times longer than wide: the gap between two
/// deck boards) under this share of a box's top: no carton top has one.
constexpr double kSlotAspect = 4.0;
constexpr double kMaxSlotShare = 0.03;
/// The slot is looked for this far (or two pixel pitches) inside the box's sides [m].
constexpr double kSlotMargin_m = 0.025;

std::string mm(double m) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(0);
  s << m * 1000.0 << " mm";
  return s.str();
}

/// Area centroid of the layer's polygons (layer frame) [m].
Eigen::Vector2d layer_centroid(const LayerResult& layer) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (const PolygonWithHoles& p : layer.polygons) {
    const double a = area(p);
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& v : p.outer) c += v;
    if (!p.outer.empty()) c /= static_cast<double>(p.outer.size());
    sum += a * c;
    total += a;
  }
  return total > 0.0 ? Eigen::Vector2d(sum / total) : Eigen::Vector2d::Zero();
}

cv::RotatedRect min_area_rect(const Ring2d& ring) {
  std::vector<cv::Point2f> pts;
  pts.reserve(ring.size());
  for (const Eigen::Vector2d& v : ring)
    pts.emplace_back(static_cast<float>(v.x() * 1000.0), static_cast<float>(v.y() * 1000.0));
  return cv::minAreaRect(pts);  // [mm]
}

double min_short_m(const std::vector<BoxFormat>& formats) {
  double s = 1e9;
  for (const BoxFormat& f : formats) s = std::min(s, f.short_m);
  return s;
}

/// The lowest known box height, 0 when no format has one [m].
double min_height_m(const std::vector<BoxFormat>& formats) {
  double h = 0.0;
  for (const BoxFormat& f : formats)
    if (f.height_m > 0.0) h = h > 0.0 ? std::min(h, f.height_m) : f.height_m;
  return h;
}

/// The level's pieces are kMinBoards or more parallel strips narrower than any box's top.
bool deck_boards(const LayerResult& layer, const std::vector<BoxFormat>& formats) {
  if (layer.polygons.size() < kMinBoards || layer.diagnostics.touches_image_border) return false;
  const double max_width_mm = kBoardWidthShare * min_short_m(formats) * 1000.0;
  std::vector<double> angles_deg;
  for (const PolygonWithHoles& p : layer.polygons) {
    if (p.outer.size() < 3) return false;
    const cv::RotatedRect r = min_area_rect(p.outer);
    const double width = std::min(r.size.width, r.size.height);
    if (width > max_width_mm) return false;
    // Direction of the strip's long side, modulo 180 degrees.
    double angle = r.angle + (r.size.width < r.size.height ? 90.0 : 0.0);
    angles_deg.push_back(std::fmod(angle + 360.0, 180.0));
  }
  for (const double a : angles_deg) {
    const double d = std::abs(a - angles_deg.front());
    if (std::min(d, 180.0 - d) > kBoardAngle_deg) return false;
  }
  return true;
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
  if (params.roi) {
    const RegionOfInterest& roi = *params.roi;
    const Eigen::Vector3d centre_camera =
        layer.T_camera_layer * Eigen::Vector3d(layer_centroid(layer).x(), layer_centroid(layer).y(), 0.0);
    const bool below = roi.frame == RegionOfInterest::Frame::kBase ? (z_m && *z_m < roi.min_m.z())
                                                                   : centre_camera.z() > roi.max_m.z();
    if (below)
      return LevelVerdict{DetectionStatus::kEmpty,
                          "nothing stands inside the region of interest: the top level lies below it"};
  }
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
                            " parallel strips narrower than any box (a pallet's deck boards)"};
  return std::nullopt;
}

namespace {

/// The camera shows a seam narrower than a pixel: a fine pitch and mixed pixels across edges.
bool resolves_seams(const LayoutResult& layout) {
  return layout.pixel_pitch_m > 0.0 && layout.pixel_pitch_m <= kResolvableSeam_m && layout.rim_share >= kMixingRimShare;
}

/// Why the camera cannot show narrow seams (for a camera where resolves_seams() is false).
std::string seam_blindness(const LayoutResult& layout) {
  return layout.pixel_pitch_m > kResolvableSeam_m
             ? "at a pixel pitch of " + mm(layout.pixel_pitch_m) + " the seams cannot be resolved"
             : "this camera shows no mixed pixels at edges (stereo, structured light or a flying-pixel "
               "filter), so seams narrower than its matching window are smoothed away";
}

/// How many of the recipe's formats the layout's boxes use.
std::size_t formats_used(const LayoutResult& layout) {
  std::vector<int> formats;
  for (const LayoutBox& b : layout.boxes) formats.push_back(b.format);
  std::sort(formats.begin(), formats.end());
  return static_cast<std::size_t>(std::unique(formats.begin(), formats.end()) - formats.begin());
}

/// Whether the piece has a hole a carton could leave (not a dropout: kDropoutHole_m).
bool has_carton_sized_hole(const PolygonWithHoles& piece) {
  return std::any_of(piece.holes.begin(), piece.holes.end(), [](const Ring2d& hole) {
    return std::abs(signed_area(hole)) >= kDropoutHole_m * kDropoutHole_m;
  });
}

}  // namespace

std::optional<LevelVerdict> formats_undecided(const LayoutResult& layout) {
  if (resolves_seams(layout)) return std::nullopt;
  std::size_t undecided = 0;
  for (const LayoutBox& b : layout.boxes) {
    if (b.evidence.split_seam >= 0.0 && b.evidence.split_seam < kSplitSeam) ++undecided;
  }
  if (undecided == 0) return std::nullopt;
  return LevelVerdict{DetectionStatus::kOk, std::to_string(undecided) +
                                                " box(es) could as well be boxes of another recipe format (one box "
                                                "where two stand side by side, or two where one stands): no seam "
                                                "is seen where they would differ and " +
                                                seam_blindness(layout)};
}

std::optional<LevelVerdict> mix_by_outline(const LayoutResult& layout) {
  const std::size_t mixed = formats_used(layout);
  if (resolves_seams(layout) || mixed < 2) return std::nullopt;
  return LevelVerdict{DetectionStatus::kOk,
                      "the layout mixes " + std::to_string(mixed) + " formats and " + seam_blindness(layout) +
                          ": another mix of the recipe's formats may fill the outline as well"};
}

std::optional<LevelVerdict> uncertain_positions(const LayoutResult& layout, const RefineParams& refine) {
  if (!(refine.max_position_sigma_mm > 0.0)) return std::nullopt;
  const double max_sigma_mm =
      std::max(refine.max_position_sigma_mm, refine.max_position_sigma_px * 1e3 * layout.pixel_pitch_m);
  std::size_t uncertain = 0, rejected = 0;
  double widest_m = 0.0;
  for (const LayoutBox& b : layout.boxes) {
    rejected += b.evidence.fit_rejected ? 1 : 0;
    if (!(1e3 * b.evidence.position_sigma_m > max_sigma_mm)) continue;
    ++uncertain;
    widest_m = std::max(widest_m, b.evidence.position_sigma_m);
  }
  std::string why;
  if (uncertain > 0)
    why = std::to_string(uncertain) + " box(es) placed less surely than " + mm(1e-3 * max_sigma_mm) +
          " (one sigma, up to " + mm(widest_m) + ") at a pixel pitch of " + mm(layout.pixel_pitch_m) +
          ": the sides that hold them are not seen well enough";
  if (rejected > 0)
    why += (why.empty() ? "" : "; ") + std::to_string(rejected) +
           " box(es) the sides seen around them would move by more than a quarter of their short side: "
           "they keep the search's place, unconfirmed";
  if (why.empty()) return std::nullopt;
  return LevelVerdict{DetectionStatus::kOk, why};
}

std::optional<LevelVerdict> undersized_boxes(const LayoutResult& layout,
                                             const std::vector<BoxFormat>& formats,
                                             const RefineParams& refine) {
  const double limit_m = std::max(refine.size_tolerance_m, kUndersize_px * layout.pixel_pitch_m);
  std::size_t undersized = 0;
  double largest_shortfall_m = 0.0;
  for (const LayoutBox& b : layout.boxes) {
    if (b.format < 0 || static_cast<std::size_t>(b.format) >= formats.size()) continue;
    const BoxFormat& f = formats[static_cast<std::size_t>(b.format)];
    const double short_of_long_m =
        b.evidence.measured_long_m < 0.0 ? 0.0 : f.long_m - b.evidence.measured_long_m;
    const double short_of_short_m =
        b.evidence.measured_short_m < 0.0 ? 0.0 : f.short_m - b.evidence.measured_short_m;
    const double shortfall_m = std::max(short_of_long_m, short_of_short_m);
    if (!(shortfall_m > limit_m)) continue;
    ++undersized;
    largest_shortfall_m = std::max(largest_shortfall_m, shortfall_m);
  }
  if (undersized == 0) return std::nullopt;
  return LevelVerdict{DetectionStatus::kOk,
                      std::to_string(undersized) + " box(es) measure up to " + mm(largest_shortfall_m) +
                          " shorter than their format between their own sides (more than " + mm(limit_m) +
                          "): a carton of another format, or two where one is laid"};
}

std::optional<LevelVerdict> search_unfinished(const LayoutResult& layout) {
  if (!layout.budget_exhausted) return std::nullopt;
  const std::string unfinished =
      "the layout search ended on its budget before it could rule out another layout ";
  if (!resolves_seams(layout))
    return LevelVerdict{DetectionStatus::kOk, unfinished + "that explains the outline as well, and " +
                                                  seam_blindness(layout) +
                                                  ": nothing but the outline decides here"};
  if (const std::size_t mixed = formats_used(layout); mixed >= 2)
    return LevelVerdict{DetectionStatus::kOk, unfinished + "of the recipe's formats: this one mixes " +
                                                  std::to_string(mixed) + " of them"};
  return std::nullopt;
}

std::optional<LevelVerdict> slip_sheet(const LayoutResult& layout, const LayerResult& layer,
                                       const std::vector<BoxFormat>& formats) {
  const InteriorSeams& seams = layout.interior_seams;
  if (layout.boxes.size() < kMinSheetBoxes || seams.length_m < min_short_m(formats)) return std::nullopt;
  if (seams.seen_share() >= kSeamlessShare) return std::nullopt;
  std::ostringstream share;
  share.precision(2);
  share << seams.seen_share();
  const bool camera_shows_seams = resolves_seams(layout);
  // A sheet lies over a whole layer: one piece whose outline is a rectangle, without holes but
  // dropouts (kDropoutHole_m). Where this camera shows seams, seamless boxes on any other shape (a
  // sheet with a torn corner or a curled edge, or sagging into a chimney) are named nothing but
  // stay in doubt: it may still be a sheet the gripper would take for cartons. Where it cannot
  // show seams, a rectangle with holes stays in doubt too (a sheet with dropouts, or cartons around
  // a chimney, look the same), any other shape is cartons.
  const bool one_piece = layer.polygons.size() == 1;
  const double rect_m2 =
      one_piece ? static_cast<double>(min_area_rect(layer.polygons.front().outer).size.area()) * 1e-6 : 0.0;
  const bool rectangle = one_piece && rect_m2 > 0.0 &&
                         std::abs(signed_area(layer.polygons.front().outer)) >= kRectangleFill * rect_m2;
  if (!rectangle || (camera_shows_seams && has_carton_sized_hole(layer.polygons.front()))) {
    if (!camera_shows_seams) return std::nullopt;
    return LevelVerdict{DetectionStatus::kOk, "no seam is seen between the boxes (" + share.str() +
                                                  " of their shared sides) where this camera shows seams, on "
                                                  "a layer that is not one plain rectangle: a slip sheet "
                                                  "cannot be ruled out"};
  }
  if (camera_shows_seams) {
    return LevelVerdict{DetectionStatus::kSlipSheet,
                        "a sheet covers the layer: one flat rectangle, seams seen along " + share.str() +
                            " of the box sides where the boxes would meet (pixel pitch " +
                            mm(layout.pixel_pitch_m) + ")"};
  }
  return LevelVerdict{DetectionStatus::kOk, "no seam is seen between the boxes (" + share.str() +
                                                " of their shared sides) and " + seam_blindness(layout) +
                                                ": a slip sheet and tightly packed cartons look the same"};
}

std::optional<LevelVerdict> deck_above_floor(const OrganizedCloud& cloud, const LayerResult& layer,
                                             const PlaneParams& validity) {
  // Heights below the layer's plane of about 10^4 sampled points, in 1 cm bins.
  constexpr double kBin_m = 0.01;
  constexpr int kBins = 400;  // down to 4 m
  std::vector<int> bins(kBins, 0);
  const int step = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(cloud.points.size()) / 1e4)));
  std::size_t sampled = 0;
  for (int v = 0; v < cloud.height; v += step) {
    for (int u = 0; u < cloud.width; u += step) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!p.allFinite() || p.z() < validity.min_depth_m || p.z() > validity.max_depth_m) continue;
      ++sampled;
      const double below_m = -layer.plane_camera.signed_distance(p.cast<double>());
      const int b = static_cast<int>(below_m / kBin_m);
      if (below_m > 0.0 && b < kBins) ++bins[static_cast<std::size_t>(b)];
    }
  }
  const auto floor_count = static_cast<int>(kMinFloorShare * static_cast<double>(sampled));
  for (int b = kBins - 2; b >= 0; --b) {
    if (bins[static_cast<std::size_t>(b)] + bins[static_cast<std::size_t>(b) + 1] < std::max(floor_count, 50))
      continue;
    const double floor_below_m = (b + 1) * kBin_m;  // the floor: the lowest level with enough points
    if (floor_below_m >= kMaxDeckAboveFloor_m) return std::nullopt;
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

std::optional<LevelVerdict> level_after_layout(const OrganizedCloud& cloud, const LayoutResult& layout,
                                               const LayerResult& layer,
                                               const std::vector<BoxFormat>& formats,
                                               const PlaneParams& validity, const RefineParams& refine) {
  // A confident layout stands; a failed or flagged one on a level as low as a pallet's deck is
  // the empty pallet (stereo cameras fill the gaps between its boards, and the deck then looks
  // like one slab that boxes tile).
  std::optional<LevelVerdict> slots =
      layout.status == DetectionStatus::kOk ? boxes_over_slots(layout, layer) : std::nullopt;
  if (layout.status != DetectionStatus::kOk || layout.ambiguous || slots)
    if (std::optional<LevelVerdict> deck = deck_above_floor(cloud, layer, validity)) return deck;
  if (slots) return slots;
  if (layout.status != DetectionStatus::kOk) return std::nullopt;
  if (std::optional<LevelVerdict> sheet = slip_sheet(layout, layer, formats)) return sheet;
  if (std::optional<LevelVerdict> undecided = formats_undecided(layout)) return undecided;
  if (std::optional<LevelVerdict> mix = mix_by_outline(layout)) return mix;
  if (std::optional<LevelVerdict> small = undersized_boxes(layout, formats, refine)) return small;
  if (std::optional<LevelVerdict> unsure = uncertain_positions(layout, refine)) return unsure;
  return search_unfinished(layout);
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
