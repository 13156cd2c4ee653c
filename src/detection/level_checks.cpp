#include "level_checks.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "level_geometry.hpp"

namespace palletd {
namespace {

using level_detail::min_area_rect;
using level_detail::min_short_m;
using level_detail::mm;
using level_detail::points_mm;

/// A piece of the layer smaller than a box that the image's edge cuts, at least this share of the
/// smallest box's top, is a carton the camera sees only part of (smaller ones are specks of depth
/// at the layer's height along the edge).
constexpr double kCutPieceShare = 0.1;
/// A layout whose boxes show seams along at least this share of the sides where they meet is a
/// layer of cartons, not a pallet's deck: a deck's gaps are slots through the level, and a layout
/// laid over its boards meets them only by chance (boxes over empty decks: at most 0.36).
constexpr double kCartonSeamShare = 0.5;
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
/// A piece of the layer at least this share of the smallest box's top that holds no box is not
/// explained by the layout (smaller ones are specks of depth at the layer's height).
constexpr double kUnlaidPieceShare = 0.5;
/// Whatever the millimetre limit, a box the joint fit places no better than this many pixel
/// pitches (and this many millimetres) flags: the sides that hold it are seen far worse than this
/// camera sees sides (exact layouts stay under 1.4 pitches on every generated set).
constexpr double kMaxSigma_px = 2.0;
constexpr double kMinSigmaLimit_mm = 5.0;
/// A box completed where the depth ends and turned more than this against the boxes seen whole
/// rests on too little of it [deg] (cartons of a layer stand square to each other within a degree
/// or two).
constexpr double kTurnedUnseen_deg = 5.0;
/// A sheet covers a whole layer: a tiling of at least this many boxes (a stepped remainder of one
/// to three cartons is no sheet).
constexpr std::size_t kMinSheetBoxes = 4;
/// Boxes (and at least half of them) whose middles show a band of tape rule out a slip sheet.
constexpr std::size_t kMinTapedBoxes = 2;
/// A seam line across a box (or between two boxes) at least this strong tells one box from two.
constexpr double kSplitSeam = 0.5;
/// A seam line seen across a box's top counts at this pixel pitch or finer, whether the camera
/// mixes depths at edges or not: a stereo camera smooths narrow seams away (their absence says
/// little), but one it does show is there. Coarser, a top spans too few pixels for a line across
/// it to be told from noise (on generated sets exact layouts show one at 12 mm per pixel) [m].
constexpr double kSeamLinePitch_m = 0.010;
/// A seam between two boxes weaker than this is not seen at all (a faint trace of a pressed seam
/// reaches 0.3-0.5 on the fine time-of-flight profiles).
constexpr double kNoSeamSeen = 0.2;
/// A layout mixing formats whose boxes show seams along less than this share of the sides where
/// they meet rests on the outline alone (the seams that would tell one mix from another are shut).
constexpr double kMixSeenShare = 0.25;
/// The rim shows mixed pixels along at least this share of the outline: the camera mixes depths
/// across an edge, so a seam narrower than a pixel still shows as a dip.
constexpr double kMixingRimShare = 0.3;

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
  // A seam measured (>= 0) and below the limit.
  const auto below = [](double seam, double limit) { return seam >= 0.0 && seam < limit; };
  if (resolves_seams(layout)) {
    // No seam seen means there is none: one box is right where two could stand, but two (or four)
    // boxes that meet without a seam are one carton of the format they make.
    std::size_t joined = 0;
    for (const LayoutBox& b : layout.boxes) joined += below(b.evidence.join_seam, kNoSeamSeen) ? 1 : 0;
    if (joined == 0) return std::nullopt;
    return LevelVerdict{DetectionStatus::kOk,
                        std::to_string(joined) +
                            " box(es) meet a box of their format where this camera shows seams and no seam "
                            "is seen between them: one carton of the recipe format they make together may "
                            "stand there"};
  }
  std::size_t undecided = 0;
  for (const LayoutBox& b : layout.boxes) {
    if (below(b.evidence.split_seam, kSplitSeam) || below(b.evidence.join_seam, kSplitSeam)) ++undecided;
  }
  if (undecided == 0) return std::nullopt;
  return LevelVerdict{DetectionStatus::kOk,
                      std::to_string(undecided) +
                          " box(es) could as well be boxes of another recipe format (one box where two "
                          "or four stand side by side, or two or four where one stands): no seam is seen "
                          "where they would differ and " +
                          seam_blindness(layout)};
}

std::optional<LevelVerdict> mix_by_outline(const LayoutResult& layout) {
  const std::size_t mixed = formats_used(layout);
  if (mixed < 2) return std::nullopt;
  const std::string why = "the layout mixes " + std::to_string(mixed) + " formats and ";
  const std::string what = ": another mix of the recipe's formats may fill the outline as well";
  if (!resolves_seams(layout)) return LevelVerdict{DetectionStatus::kOk, why + seam_blindness(layout) + what};
  // A camera that shows seams, on cartons pressed together: the mix rests on the outline alone.
  const InteriorSeams& seams = layout.interior_seams;
  if (seams.length_m <= 0.0 || seams.seen_share() >= kMixSeenShare) return std::nullopt;
  std::ostringstream share;
  share.precision(2);
  share << seams.seen_share();
  return LevelVerdict{DetectionStatus::kOk, why + "seams show along only " + share.str() +
                                                " of the sides where its boxes meet" + what};
}

std::optional<LevelVerdict> seams_across_boxes(const LayoutResult& layout) {
  if (!(layout.pixel_pitch_m > 0.0 && layout.pixel_pitch_m <= kSeamLinePitch_m)) return std::nullopt;
  std::size_t crossed = 0;
  double strongest = 0.0;
  for (const LayoutBox& b : layout.boxes) {
    if (!(b.evidence.interior_seam >= kSplitSeam)) continue;
    ++crossed;
    strongest = std::max(strongest, b.evidence.interior_seam);
  }
  if (crossed == 0) return std::nullopt;
  std::ostringstream strength;
  strength.precision(2);
  strength << strongest;
  return LevelVerdict{DetectionStatus::kOk,
                      std::to_string(crossed) +
                          " box(es) have a seam line across their top (strength up to " + strength.str() +
                          "): the cartons stand otherwise "
                          "(a mirrored pinwheel, a shifted row)"};
}

std::optional<LevelVerdict> uncertain_positions(const LayoutResult& layout, const RefineParams& refine) {
  if (!(refine.max_position_sigma_mm > 0.0)) return std::nullopt;
  const double pitch_mm = 1e3 * layout.pixel_pitch_m;
  const double max_sigma_mm =
      std::min(std::max(refine.max_position_sigma_mm, refine.max_position_sigma_px * pitch_mm),
               std::max(kMaxSigma_px * pitch_mm, kMinSigmaLimit_mm));
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

std::optional<LevelVerdict> uncertain_turn(const LayoutResult& layout, const RefineParams& refine) {
  if (!(refine.max_yaw_sigma_deg > 0.0)) return std::nullopt;
  double widest_rad = 0.0;
  for (const LayoutBox& b : layout.boxes) widest_rad = std::max(widest_rad, b.evidence.yaw_sigma_rad);
  const double widest_deg = widest_rad * 180.0 / M_PI;
  if (!(widest_deg > refine.max_yaw_sigma_deg)) return std::nullopt;
  std::ostringstream s;
  s.precision(2);
  s << "the layer's turn is measured to " << widest_deg << " degrees (one sigma, over "
    << refine.max_yaw_sigma_deg << ") at a pixel pitch of " << mm(layout.pixel_pitch_m)
    << ": the sides seen are too few pixels long to turn the boxes surely";
  return LevelVerdict{DetectionStatus::kOk, s.str()};
}

std::optional<LevelVerdict> turned_unseen_boxes(const LayoutResult& layout) {
  const auto seen = std::find_if(layout.boxes.begin(), layout.boxes.end(),
                                 [](const LayoutBox& b) { return !b.partly_unseen; });
  if (seen == layout.boxes.end()) return std::nullopt;
  const double quarter = 0.5 * M_PI;
  std::size_t turned = 0;
  double most_deg = 0.0;
  for (const LayoutBox& b : layout.boxes) {
    if (!b.partly_unseen) continue;
    const double d = std::remainder(b.yaw_rad - seen->yaw_rad, quarter);  // within +/- 45 degrees
    const double d_deg = std::abs(d) * 180.0 / M_PI;
    if (d_deg <= kTurnedUnseen_deg) continue;
    ++turned;
    most_deg = std::max(most_deg, d_deg);
  }
  if (turned == 0) return std::nullopt;
  std::ostringstream s;
  s << turned << " box(es) completed where the depth ends stand turned by up to " << std::lround(most_deg)
    << " degrees against the boxes seen whole: the part seen cannot tell a turned carton from a box fitted "
       "askew to a few edges";
  return LevelVerdict{DetectionStatus::kOk, s.str()};
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

std::optional<LevelVerdict> overlapping_boxes(const LayoutResult& layout, const RefineParams& refine) {
  std::vector<std::vector<cv::Point2f>> corners_mm;
  corners_mm.reserve(layout.boxes.size());
  for (const LayoutBox& b : layout.boxes) corners_mm.push_back(points_mm(b.corners()));
  double deepest_mm = 0.0;
  std::size_t first = 0, second = 0;
  for (std::size_t i = 0; i < layout.boxes.size(); ++i) {
    const LayoutBox& a = layout.boxes[i];
    for (std::size_t j = i + 1; j < layout.boxes.size(); ++j) {
      const LayoutBox& b = layout.boxes[j];
      const double reach_m = 0.5 * (std::hypot(a.long_m, a.short_m) + std::hypot(b.long_m, b.short_m));
      if ((a.center - b.center).norm() >= reach_m) continue;  // too far apart to touch
      std::vector<cv::Point2f> shared;
      if (cv::intersectConvexConvex(corners_mm[i], corners_mm[j], shared) <= 0.0F || shared.size() < 3) continue;
      const cv::RotatedRect r = cv::minAreaRect(shared);
      const double depth_mm = std::min(r.size.width, r.size.height);  // how far one reaches into the other
      if (depth_mm > deepest_mm) deepest_mm = depth_mm, first = i, second = j;
    }
  }
  if (!(deepest_mm > 1e3 * refine.size_tolerance_m)) return std::nullopt;
  return LevelVerdict{DetectionStatus::kOk, "boxes " + std::to_string(first) + " and " +
                                                std::to_string(second) + " overlap by " +
                                                mm(1e-3 * deepest_mm) +
                                                ": the layout holds more cartons than the layer has room for "
                                                "(cartons built over their format, fewer of them)"};
}

std::optional<LevelVerdict> pieces_without_boxes(const LayoutResult& layout, const LayerResult& layer,
                                                 const std::vector<BoxFormat>& formats) {
  const double smallest_m2 = level_detail::min_area_m2(formats);
  std::vector<bool> holds_box(layer.polygons.size(), false);
  for (const LayoutBox& b : layout.boxes)
    if (b.component >= 0 && static_cast<std::size_t>(b.component) < holds_box.size())
      holds_box[static_cast<std::size_t>(b.component)] = true;
  std::size_t pieces = 0;
  double largest_m2 = 0.0;
  for (std::size_t i = 0; i < layer.polygons.size(); ++i) {
    const double a_m2 = area(layer.polygons[i]);
    if (holds_box[i] || !(a_m2 >= kUnlaidPieceShare * smallest_m2)) continue;
    ++pieces;
    largest_m2 = std::max(largest_m2, a_m2);
  }
  if (pieces == 0) return std::nullopt;
  std::ostringstream size;
  size.precision(2);
  size << largest_m2 / smallest_m2;
  return LevelVerdict{DetectionStatus::kOk, std::to_string(pieces) +
                                                " piece(s) of the layer hold no box (the largest " +
                                                size.str() +
                                                " times the smallest box's top): something at the layer's "
                                                "height that no carton of the recipe explains"};
}

std::optional<LevelVerdict> pieces_cut_by_image(const LayerResult& layer,
                                                const std::vector<BoxFormat>& formats) {
  const double smallest_m2 = level_detail::min_area_m2(formats);
  const double cut_m2 = layer.diagnostics.largest_cut_piece_m2;
  if (!(cut_m2 >= kCutPieceShare * smallest_m2)) return std::nullopt;
  std::ostringstream size;
  size.precision(2);
  size << cut_m2 / smallest_m2;
  return LevelVerdict{DetectionStatus::kOk,
                      "the image's edge cuts off part of the layer too small to place a box "
                      "on (the largest " +
                          size.str() + " times the smallest box's top): the boxes there are not reported"};
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
  // Tape along the middles of many of the boxes: cartons pressed together, not a plain sheet.
  if (seams.taped_boxes >= std::max(kMinTapedBoxes, layout.boxes.size() / 2)) return std::nullopt;
  std::ostringstream share;
  share.precision(2);
  share << seams.seen_share();
  const bool camera_shows_seams = resolves_seams(layout);
  // A sheet lies over a whole layer: one piece whose outline is a rectangle, without holes but
  // dropouts (kDropoutHole_m). Where this camera shows seams, seamless boxes on any other shape (a
  // sheet with a torn corner or a curled edge, or sagging into a chimney) are named nothing but
  // stay in doubt: it may still be a sheet the gripper would take for cartons. Where it cannot
  // show seams, a rectangle with holes stays in doubt too (a sheet with dropouts, or cartons around
  // a chimney, look the same), and so does an outline cut where the depth or the image ends; any
  // other shape is cartons.
  const bool one_piece = layer.polygons.size() == 1;
  const double rect_m2 =
      one_piece ? static_cast<double>(min_area_rect(layer.polygons.front().outer).size.area()) * 1e-6 : 0.0;
  const bool rectangle = one_piece && rect_m2 > 0.0 &&
                         std::abs(signed_area(layer.polygons.front().outer)) >= kRectangleFill * rect_m2;
  if (!rectangle || (camera_shows_seams && has_carton_sized_hole(layer.polygons.front()))) {
    // An outline cut where the depth or the image ends shows no shape: the sheet may go on unseen.
    const LayerDiagnostics& seen = layer.diagnostics;
    if (!camera_shows_seams && (seen.outline_along_invalid || seen.touches_image_border)) {
      return LevelVerdict{DetectionStatus::kOk, "no seam is seen between the boxes (" + share.str() +
                                                    " of their shared sides) and " + seam_blindness(layout) +
                                                    ", on a layer whose outline runs where the " +
                                                    (seen.outline_along_invalid ? "depth" : "image") +
                                                    " ends: a slip sheet cannot be ruled out"};
    }
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

std::optional<LevelVerdict> level_after_layout(const OrganizedCloud& cloud, const LayoutResult& layout,
                                               const LayerResult& layer,
                                               const std::vector<BoxFormat>& formats,
                                               const PlaneParams& validity, const RefineParams& refine,
                                               const std::optional<Eigen::Isometry3d>& T_base_camera,
                                               std::optional<double> above_deck_m) {
  // A confident layout stands; a failed or flagged one, or one with boxes over slots or holes or
  // pieces of the layer without boxes or cut off by the image's edge, on a level as low as a
  // pallet's deck is the empty pallet (stereo cameras and coarse pitches merge its boards and gaps
  // into strips or one slab that boxes tile). Where the pallet's height is known, it alone decides;
  // boxes whose seams show where they meet are cartons. A search the clock ended has not shown
  // that no box fits: a slow or loaded machine must not make a layer of cartons an empty pallet
  // (the expansion count ends a search the same way on every machine, and sets are measured so).
  const bool ok = layout.status == DetectionStatus::kOk;
  std::optional<LevelVerdict> slots = ok ? boxes_over_slots(layout, layer) : std::nullopt;
  std::optional<LevelVerdict> unlaid = ok ? pieces_without_boxes(layout, layer, formats) : std::nullopt;
  std::optional<LevelVerdict> holes = ok ? boxes_over_holes(cloud, layout, layer) : std::nullopt;
  std::optional<LevelVerdict> cut = ok ? pieces_cut_by_image(layer, formats) : std::nullopt;
  const bool carton_seams = ok && layout.interior_seams.seen_share() >= kCartonSeamShare;
  if (!above_deck_m && !carton_seams && !layout.clock_ran_out &&
      (!ok || layout.ambiguous || slots || unlaid || holes || cut))
    if (std::optional<LevelVerdict> deck = deck_above_floor(cloud, layer, validity, T_base_camera))
      return deck;
  if (slots) return slots;
  if (unlaid) return unlaid;
  if (holes) return holes;
  if (!ok) return std::nullopt;
  if (std::optional<LevelVerdict> sheet = slip_sheet(layout, layer, formats)) {
    if (sheet->status != DetectionStatus::kSlipSheet) return sheet;
    const auto beside =
        lower_level_beside(cloud, layer, formats, validity, layout.pixel_pitch_m, above_deck_m);
    return beside ? rest_of_a_layer(*beside, layout) : *sheet;
  }
  if (cut) return cut;
  if (std::optional<LevelVerdict> undecided = formats_undecided(layout)) return undecided;
  if (std::optional<LevelVerdict> mix = mix_by_outline(layout)) return mix;
  if (std::optional<LevelVerdict> crossed = seams_across_boxes(layout)) return crossed;
  if (std::optional<LevelVerdict> small = undersized_boxes(layout, formats, refine)) return small;
  if (std::optional<LevelVerdict> unsure = uncertain_positions(layout, refine)) return unsure;
  if (std::optional<LevelVerdict> askew = uncertain_turn(layout, refine)) return askew;
  if (std::optional<LevelVerdict> turned = turned_unseen_boxes(layout)) return turned;
  if (std::optional<LevelVerdict> crowded = overlapping_boxes(layout, refine)) return crowded;
  return search_unfinished(layout);
}

}  // namespace palletd
