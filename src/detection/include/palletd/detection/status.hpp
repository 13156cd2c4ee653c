// palletd detection: how a detection ended, shared by every stage's result.
#pragma once

namespace palletd {

/// kEmpty: the top level inside the region of interest is the empty pallet, or nothing stands
/// above it. kSlipSheet: a sheet covers the layer. Both come with no boxes and are no failure of
/// the frame.
/// kRecipeMismatch: the boxes' measured sides disagree with the recipe's formats (the layer is
/// built of other cartons); a failure, with no boxes.
enum class DetectionStatus { kOk, kNoPlane, kNoLayer, kNoLayout, kBadFrame, kEmpty, kSlipSheet, kRecipeMismatch };
/// "ok", "no_plane", "no_layer", "no_layout", "bad_frame", "empty", "slip_sheet", "recipe_mismatch" (the words of
/// shared/spec/detections.md).
const char* to_string(DetectionStatus status);
/// The frame could not be answered (no_plane, no_layer, no_layout, bad_frame, recipe_mismatch); ok, empty and
/// slip_sheet are answers.
bool is_failure(DetectionStatus status);

/// Why a layout is flagged ambiguous, as a category (Detection::ambiguity_reason says it in words):
/// near-equal layouts the seams cannot separate, a search that ended at its budget, a part of the
/// layer no box explains, a level check that doubts the layout (a slip sheet the pixel pitch
/// cannot tell, boxes over deck slots), a height that is no whole number of layers.
enum class AmbiguityKind { kTiedLayouts, kSearchBudget, kUnexplainedArea, kLevelCheck, kHeightOffLayers };
/// "tied_layouts", "search_budget", "unexplained_area", "level_check", "height_off_layers".
const char* to_string(AmbiguityKind kind);

}  // namespace palletd
