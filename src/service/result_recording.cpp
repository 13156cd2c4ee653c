#include "result_recording.hpp"

#include <spdlog/spdlog.h>

#include "palletd/results/detection_json.hpp"
#include "palletd/results/overlay.hpp"

namespace palletd {

ResultRecording::ResultRecording(const Config& cfg) {
  if (cfg.recording.enabled)
    recorder_ =
        std::make_unique<FrameRecorder>(RecorderOptions{cfg.recording.directory, cfg.recording.max_bytes});
}

void ResultRecording::after_result(const Config& cfg, const ResultSnapshot& snapshot) {
  const bool asked = asked_.exchange(false);
  if (!recorder_ || !snapshot.frame || !(asked || cfg.recording.every_trigger)) return;
  const std::string json = detection_to_json_line(snapshot.detection, "");
  std::vector<std::uint8_t> overlay;
  if (cfg.recording.overlays)
    overlay =
        render_overlay_png(*snapshot.frame, snapshot.detection, snapshot.check ? &*snapshot.check : nullptr);
  Expected<std::string> stem = recorder_->record(*snapshot.frame, json, overlay);
  std::lock_guard<std::mutex> lock(error_mutex_);
  if (!stem) {
    failures_.fetch_add(1);
    last_error_ = stem.error();
    spdlog::error("recording: {}", stem.error());
  } else {
    recordings_.fetch_add(1);
    last_error_.clear();
    spdlog::info("recorded {}", *stem);
  }
}

std::string ResultRecording::last_error() const {
  std::lock_guard<std::mutex> lock(error_mutex_);
  return last_error_;
}

}  // namespace palletd
