#include "shadow.hpp"

#include <pthread.h>
#include <sched.h>
#include <spdlog/spdlog.h>

#include "palletd/detection/detection.hpp"
#include "palletd/results/comparison.hpp"
#include "palletd/results/detection_json.hpp"
#include "palletd/results/overlay.hpp"

#include "recipe_detection.hpp"

namespace palletd {

ShadowRunner::ShadowRunner(std::shared_ptr<const Config> shadow, std::optional<RecorderOptions> record,
                           double moved_mm)
    : moved_mm_(moved_mm), config_(std::move(shadow)) {
  if (record) recorder_ = std::make_unique<FrameRecorder>(std::move(*record));
  counters_.enabled = config_ != nullptr;
  thread_ = std::thread([this] { run(); });
}

ShadowRunner::~ShadowRunner() { stop(); }

void ShadowRunner::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void ShadowRunner::set_config(std::shared_ptr<const Config> shadow) {
  std::lock_guard<std::mutex> lock(mutex_);
  config_ = std::move(shadow);
  counters_.enabled = config_ != nullptr;
}

void ShadowRunner::submit(std::shared_ptr<const ResultSnapshot> live) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!config_) return;
    if (job_) ++counters_.skipped;
    job_ = std::move(live);
  }
  cv_.notify_one();
}

ShadowCounters ShadowRunner::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

void ShadowRunner::run() {
  // Idle priority: the shadow runs only on a core the live pipeline leaves free.
  sched_param idle{};
  (void)pthread_setschedparam(pthread_self(), SCHED_IDLE, &idle);
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stopping_ || job_ != nullptr; });
    if (stopping_) return;
    std::shared_ptr<const ResultSnapshot> live = std::move(job_);
    std::shared_ptr<const Config> shadow = config_;
    lock.unlock();
    try {
      if (shadow && live->frame) compare(*live, *shadow);
    } catch (const std::exception& e) {
      spdlog::error("shadow configuration: trigger {}: {}", live->trigger_seq, e.what());
    }
    lock.lock();
  }
}

void ShadowRunner::compare(const ResultSnapshot& live, const Config& shadow) {
  const Recipe* recipe = find_recipe(shadow, live.recipe);
  if (recipe == nullptr) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.skipped;
    return;
  }
  Frame frame = *live.frame;
  apply_calibration(shadow, frame);
  DetectionWorkspace workspace;
  const Detection result = detect_recipe(shadow, *recipe, frame, workspace);
  const DetectionDifference diff = compare_detections(live.detection, result, moved_mm_);
  if (!diff.any()) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.runs;
    return;
  }
  const std::string text =
      "trigger " + std::to_string(live.trigger_seq) + ": " + diff.describe(live.detection, result);
  spdlog::info("shadow configuration disagrees: {} (live -> shadow)", text);
  if (recorder_) {
    const Expected<std::string> stem =
        recorder_->record(*live.frame, detection_to_json_line(live.detection, ""),
                          render_overlay_png(*live.frame, live.detection));
    if (!stem) spdlog::warn("shadow configuration: cannot record the frame: {}", stem.error());
  }
  // Counted once recorded: a reader that sees the count finds the frame.
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_.runs;
  ++counters_.disagreements;
  counters_.last_difference = text;
}

std::unique_ptr<ShadowRunner> make_shadow(const Config& config) {
  constexpr double kMovedMm = 5.0;
  std::optional<RecorderOptions> record;
  if (config.recording.enabled)
    record = RecorderOptions{config.recording.directory + "/shadow", config.recording.max_bytes / 8};
  return std::make_unique<ShadowRunner>(config.shadow, std::move(record), kMovedMm);
}

}  // namespace palletd
