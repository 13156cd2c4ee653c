// palletd detection: how a detection ended, shared by every stage's result.
#pragma once

namespace palletd {

enum class DetectionStatus { kOk, kNoPlane, kNoLayer, kNoLayout, kBadFrame };
/// "ok", "no_plane", "no_layer", "no_layout", "bad_frame" (the words of shared/spec/detections.md).
const char* to_string(DetectionStatus status);

}  // namespace palletd
