// detect(): the named stages of the pipeline, composed. Filled in when the stages land.
#include "palletd/detection.hpp"

namespace palletd {

const char* to_string(DetectionStatus status) {
  switch (status) {
    case DetectionStatus::ok: return "ok";
    case DetectionStatus::no_plane: return "no_plane";
    case DetectionStatus::no_layer: return "no_layer";
    case DetectionStatus::no_layout: return "no_layout";
    case DetectionStatus::bad_frame: return "bad_frame";
  }
  return "bad_frame";
}

}  // namespace palletd
