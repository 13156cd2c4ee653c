// palletd detection: how a detection ended, shared by every stage's result.
#pragma once

namespace palletd {

/// kEmpty: the top level inside the region of interest is the empty pallet, or nothing stands
/// above it. kSlipSheet: a sheet covers the layer. Both come with no boxes and are no failure of
/// the frame.
enum class DetectionStatus { kOk, kNoPlane, kNoLayer, kNoLayout, kBadFrame, kEmpty, kSlipSheet };
/// "ok", "no_plane", "no_layer", "no_layout", "bad_frame", "empty", "slip_sheet" (the words of
/// shared/spec/detections.md).
const char* to_string(DetectionStatus status);
/// The frame could not be answered (no_plane, no_layer, no_layout, bad_frame); ok, empty and
/// slip_sheet are answers.
bool is_failure(DetectionStatus status);

}  // namespace palletd
