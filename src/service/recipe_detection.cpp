// detect_recipe() and warm_up(): see recipe_detection.hpp.
#include "recipe_detection.hpp"

#include <chrono>
#include <vector>

#include <spdlog/spdlog.h>

#include "palletd/core/timing.hpp"
#include "palletd/detection/unknown_cartons.hpp"

namespace palletd {

const Recipe* find_recipe(const Config& config, int number) {
  for (const Recipe& r : config.recipes)
    if (r.number == number) return &r;
  return nullptr;
}

void apply_calibration(const Config& config, Frame& frame) {
  if (config.T_base_camera) frame.T_base_camera = config.T_base_camera;
}

Detection detect_recipe(const Config& config, const Recipe& recipe, const Frame& frame,
                        DetectionWorkspace& workspace) {
  if (recipe.size_range)
    return detect_unknown_cartons(frame, *recipe.size_range, config.detection, workspace);
  std::vector<BoxFormat> formats;
  for (int index : recipe.formats) formats.push_back(config.formats[static_cast<std::size_t>(index)]);
  return detect(frame, formats, config.detection, workspace);
}

double warm_up(Acquisition& acquisition, const Config& config, DetectionWorkspace& workspace) {
  const Recipe* recipe = find_recipe(config, config.pipeline.default_recipe);
  if (recipe == nullptr) return -1.0;
  Expected<Frame> grabbed =
      acquisition.frame_after(std::chrono::steady_clock::now(),
                              std::chrono::milliseconds(static_cast<long>(config.camera.frame_timeout_ms)));
  if (!grabbed) {
    spdlog::info("warm-up detection skipped: {}", grabbed.error());
    return -1.0;
  }
  Frame frame = std::move(grabbed).value();
  apply_calibration(config, frame);
  const auto t0 = std::chrono::steady_clock::now();
  const Detection detection = detect_recipe(config, *recipe, frame, workspace);
  const double elapsed_ms = ms_since(t0);
  spdlog::info("warm-up detection on the first frame (recipe {}): {} in {:.0f} ms", recipe->number,
               to_string(detection.status), elapsed_ms);
  return elapsed_ms;
}

}  // namespace palletd
