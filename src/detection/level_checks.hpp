// Stages around the layout: what the top level is before boxes are looked for (the empty pallet,
// nothing inside the region of interest), whether the boxes found are a slip sheet, and the
// layer's height above the pallet.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"

namespace palletd {

/// A verdict on the top level that ends the frame without boxes (kEmpty, kSlipSheet) or flags it.
struct LevelVerdict {
  DetectionStatus status = DetectionStatus::kOk;
  std::string message;
};

/// The top level's height in the base frame at the centre of the layer's area [m]; null
/// without camera_to_base.
std::optional<double> layer_base_z_m(const LayerResult& layer,
                                     const std::optional<Eigen::Isometry3d>& T_base_camera);

/// kEmpty when the top level found is no level of boxes: it lies below the region of interest,
/// it is the pallet's deck (PalletParams::top_z_m), or without a pallet height its pieces are
/// parallel strips narrower than any box (deck boards) and nothing else stands above them.
std::optional<LevelVerdict> empty_level(const Frame& frame, const LayerResult& layer,
                                        const std::vector<BoxFormat>& formats, const DetectionParams& params);

/// After a layout failed: the top level stands 0.08-0.2 m above the lowest large level in
/// view (the floor, at least a tenth of the sampled points), lower than any carton layer on a
/// pallet, so it is an empty pallet's deck (kEmpty). Heights along the base's up axis from the
/// level's centre when `T_base_camera` is known, else from the layer's plane.
std::optional<LevelVerdict> deck_above_floor(const OrganizedCloud& cloud, const LayerResult& layer,
                                             const PlaneParams& validity,
                                             const std::optional<Eigen::Isometry3d>& T_base_camera);

/// A layout whose interior box sides show no seam anywhere while the layer is one rectangle: a
/// sheet covers the layer (kSlipSheet) where the sensor resolves seams; where it cannot, the
/// result is flagged (kOk with a message for ambiguity_reason), holes in the rectangle or not (a
/// sheet's depth drops out in places). On a layer of any other shape, or a rectangle with holes,
/// it is flagged where the sensor resolves seams (a torn or holed sheet), else left alone. Tape
/// along the middles of at least two boxes and half of them (InteriorSeams::taped_boxes) is
/// cartons pressed together: no sheet, whatever the seams.
std::optional<LevelVerdict> slip_sheet(const LayoutResult& layout, const LayerResult& layer,
                                       const std::vector<BoxFormat>& formats);

/// The next level of the load seen beside the top level: a flat level 0.08-0.8 m below the
/// layer's plane (above the floor, the deepest level holding a tenth of the points around), from
/// 60 mm out to the recipe's longest short side (0.25 m at least) outside its outline, covering at
/// least the recipe's smallest top. A layer partly picked shows it; a slip sheet lies over a whole
/// layer and hides it. `pixel_pitch_m`: the raster's cell is no finer (1 cm at least).
/// `above_deck_m`: the layer's height above the pallet's top; a level less than 50 mm above the
/// deck is left out (a roller conveyor at pallet height beside the pallet).
struct LevelBeside {
  double drop_m = 0.0;   ///< how far below the top level [m]
  double area_m2 = 0.0;  ///< how much of it shows within reach [m^2]
};
std::optional<LevelBeside> lower_level_beside(const OrganizedCloud& cloud, const LayerResult& layer,
                                              const std::vector<BoxFormat>& formats,
                                              const PlaneParams& validity, double pixel_pitch_m,
                                              std::optional<double> above_deck_m = std::nullopt);

/// A seamless rectangle that slip_sheet() names a sheet, with the load's next level beside it: a
/// sheet lies over a whole layer, so it is more likely what is left of a layer of cartons pressed
/// together; flagged (kOk with the sentence), a sheet not ruled out.
LevelVerdict rest_of_a_layer(const LevelBeside& beside, const LayoutResult& layout);

/// A box that two boxes of another recipe format could replace, or a pair or a block of four one
/// box could (LayoutBox evidence split_seam, join_seam), with no seam seen across it, on a camera
/// that does not show narrow seams (a coarse pitch, or no mixed pixels at edges): the outline is
/// the same either way and nothing in the frame decides, so the layout is flagged (kOk with the
/// sentence). On a camera that shows them, a pair or block with no seam seen at all between its
/// boxes is flagged: it is one carton as far as the frame shows.
std::optional<LevelVerdict> formats_undecided(const LayoutResult& layout);

/// A layout of two or more formats on a camera that does not show narrow seams, or whose boxes
/// show seams along less than a quarter of the sides where they meet (pressed together): the
/// formats are told apart by the outline alone, and another mix of them may fill it as well:
/// flagged (kOk).
std::optional<LevelVerdict> mix_by_outline(const LayoutResult& layout);

/// A piece of the layer the image's edge cuts off (LayerDiagnostics::largest_cut_piece_m2) too
/// small to be kept as part of the layer, yet a sizeable share of the smallest box's top: a
/// carton the camera sees only part of, which the layout cannot hold: flagged (kOk).
std::optional<LevelVerdict> pieces_cut_by_image(const LayerResult& layer,
                                                const std::vector<BoxFormat>& formats);

/// Boxes with a seam line across their top at least as strong as one that tells one box from two
/// (LayoutBox evidence interior_seam >= 0.5), at a pixel pitch of 10 mm or finer (a stereo camera
/// included: it hides narrow seams, but one it shows is there): no carton's top shows one, so the
/// cartons stand otherwise than laid out (a pinwheel's mirror image, a row shifted by part of a
/// carton): flagged (kOk).
std::optional<LevelVerdict> seams_across_boxes(const LayoutResult& layout);

/// Boxes whose own two opposite sides (LayoutBox evidence measured_long_m / measured_short_m)
/// measure them shorter than their format by more than refine.size_tolerance_m and two pixel
/// pitches: flagged (kOk); another format, or two cartons taken for one.
std::optional<LevelVerdict> undersized_boxes(const LayoutResult& layout,
                                             const std::vector<BoxFormat>& formats,
                                             const RefineParams& refine);

/// Two boxes of the fitted layout that reach into each other deeper than refine.size_tolerance_m
/// (cartons do not pass through each other): the layout holds more cartons than stand there, as
/// when cartons built 5 % over their format fill the room of one more nominal carton: flagged (kOk).
std::optional<LevelVerdict> overlapping_boxes(const LayoutResult& layout, const RefineParams& refine);

/// Boxes whose fitted position is uncertain (one sigma; LayoutBox evidence position_sigma_m) by
/// more than refine.max_position_sigma_mm and more than refine.max_position_sigma_px pixel
/// pitches, or by more than two pitches and 5 mm whatever those limits, or whose fit was rejected (evidence
/// fit_rejected: the sides seen around it would move it by more than a quarter of its short side): flagged
/// (kOk); max_position_sigma_mm 0 = never.
std::optional<LevelVerdict> uncertain_positions(const LayoutResult& layout, const RefineParams& refine);

/// The layer's turn uncertain (one sigma; LayoutBox evidence yaw_sigma_rad) by more than
/// refine.max_yaw_sigma_deg: flagged (kOk); 0 = never.
std::optional<LevelVerdict> uncertain_turn(const LayoutResult& layout, const RefineParams& refine);

/// Boxes completed where the depth ends (partly_unseen) whose yaw differs from the boxes seen
/// whole by more than 5 degrees (modulo a quarter turn): the part seen cannot tell a turned
/// carton from a box fitted askew to a few edges: flagged (kOk). Nothing without a box seen whole.
std::optional<LevelVerdict> turned_unseen_boxes(const LayoutResult& layout);

/// The search ended on its budget (LayoutResult::budget_exhausted) on a camera that does not show
/// narrow seams (only the outline decides, and the search stopped before it could rule out
/// another layout explaining it as well: a pinwheel's mirror, other formats), or on any camera
/// with a layout that mixes formats (the mixes were not all weighed): flagged (kOk).
std::optional<LevelVerdict> search_unfinished(const LayoutResult& layout);

/// A piece of the layer (one of its polygons) at least half as large as the recipe's smallest box
/// that holds no box: something stands at the layer's height that no carton of the recipe explains
/// (a carton of another format, the strips of an empty pallet's deck, a fixture): flagged (kOk).
std::optional<LevelVerdict> pieces_without_boxes(const LayoutResult& layout, const LayerResult& layer,
                                                 const std::vector<BoxFormat>& formats);

/// Boxes whose top, read in the depth at least 25 mm (or two pixel pitches) inside their sides,
/// lies more than 40 mm below the layer's plane over at least a tenth of its samples: the layout
/// put a carton over a hole the outline lost (a chimney, a carton already picked): flagged (kOk).
std::optional<LevelVerdict> boxes_over_holes(const OrganizedCloud& cloud, const LayoutResult& layout,
                                             const LayerResult& layer);

/// A box of the layout lies over a slot in the layer (a hole four times longer than wide under
/// more than 3 % of its top): flagged (kOk with the sentence); the gaps of a pallet's deck look so.
std::optional<LevelVerdict> boxes_over_slots(const LayoutResult& layout, const LayerResult& layer);

/// After the layout: deck_above_floor when the layout failed or is flagged, or a box covers a slot
/// or a hole, or a piece of the layer holds no box or the image's edge cuts one off, and the
/// search was not ended by the clock (LayoutResult::clock_ran_out: then nothing showed that no box
/// fits, and a faster machine might have); then those
/// flags; else slip_sheet (rest_of_a_layer where lower_level_beside finds one), pieces_cut_by_image,
/// formats_undecided, mix_by_outline, seams_across_boxes, undersized_boxes, uncertain_positions,
/// uncertain_turn, turned_unseen_boxes, overlapping_boxes (`refine`), search_unfinished. `above_deck_m`: the
/// layer's height above the pallet's top when the pallet's height and the calibration give it (empty_level()
/// found it no deck), so no floor seen below it makes it one: the level seen lowest may be a lower layer of
/// cartons; and a level beside it counts as the load's next level only above the deck.
std::optional<LevelVerdict> level_after_layout(const OrganizedCloud& cloud, const LayoutResult& layout,
                                               const LayerResult& layer,
                                               const std::vector<BoxFormat>& formats,
                                               const PlaneParams& validity, const RefineParams& refine,
                                               const std::optional<Eigen::Isometry3d>& T_base_camera,
                                               std::optional<double> above_deck_m);

/// Fills height_above_pallet_m and layers_remaining; flags the result (ambiguous, with a reason)
/// when the height is not a whole number of box heights.
void layer_height(const std::optional<double>& layer_z_m, const std::vector<BoxFormat>& formats,
                  const PalletParams& pallet, Detection& out);

}  // namespace palletd
