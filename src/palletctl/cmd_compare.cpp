// palletctl compare: two configurations on the same recorded frames, and every frame whose result
// differs (status, box count, a box moved, formats, the ambiguous flag); the check before a reload.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "palletd/detection/detection.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/results/comparison.hpp"
#include "palletd/results/overlay.hpp"

#include "commands.hpp"
#include "detect_common.hpp"

namespace palletd {

namespace {

struct CompareArgs {
  std::vector<std::string> configs;
  int recipe = 0;
  std::vector<std::string> boxes;
  double moved_mm = 5.0;
  std::string overlay_dir;
  bool json = false;
  std::vector<std::string> frames;
};

nlohmann::json summary(const Detection& d) {
  return {{"status", to_string(d.status)}, {"boxes", d.boxes.size()}, {"ambiguous", d.ambiguous}};
}

/// Detects one frame under both setups; prints and draws it when the results differ. The
/// frame's own camera_to_base stays unless a configuration has one.
bool compare_frame(const CompareArgs& a, const std::string& stem, const Frame& frame,
                   const DetectSetup (&setup)[2], DetectionWorkspace (&workspace)[2]) {
  Detection d[2];
  for (int k = 0; k < 2; ++k) {
    Frame f = frame;
    if (setup[k].T_base_camera) f.T_base_camera = setup[k].T_base_camera;
    d[k] = detect(f, setup[k].formats, setup[k].params, workspace[k]);
  }
  const DetectionDifference diff = compare_detections(d[0], d[1], a.moved_mm);
  if (!diff.any()) return false;
  if (a.json) {
    const nlohmann::json line = {{"frame", stem},
                                 {"a", summary(d[0])},
                                 {"b", summary(d[1])},
                                 {"boxes_moved", diff.boxes_moved},
                                 {"max_move_mm", diff.max_move_mm},
                                 {"difference", diff.describe(d[0], d[1])}};
    std::printf("%s\n", line.dump().c_str());
  } else {
    std::printf("%s: %s\n", stem.c_str(), diff.describe(d[0], d[1]).c_str());
  }
  std::fflush(stdout);
  if (!a.overlay_dir.empty()) {
    const std::string name = std::filesystem::path(stem).filename().string();
    write_bytes(std::filesystem::path(a.overlay_dir) / (name + ".a.overlay.png"),
                render_overlay_png(frame, d[0]));
    write_bytes(std::filesystem::path(a.overlay_dir) / (name + ".b.overlay.png"),
                render_overlay_png(frame, d[1]));
  }
  return true;
}

/// 0: every frame gives the same result; 1: some differ; 2: a frame or a configuration could not be read.
int run_compare(const CompareArgs& a) {
  if (a.configs.size() != 2) {
    spdlog::error("give --config twice: A (the running configuration) and B (the candidate)");
    return 2;
  }
  const DetectSetup setup[2] = {make_detect_setup(a.configs[0], a.recipe, a.boxes),
                                make_detect_setup(a.configs[1], a.recipe, a.boxes)};
  if (setup[0].formats.empty()) {
    spdlog::error("no box format: give --recipe N (in both configurations) or --box LxW (mm)");
    return 2;
  }
  if (!a.overlay_dir.empty()) std::filesystem::create_directories(a.overlay_dir);
  DetectionWorkspace workspace[2];
  int frames = 0, differing = 0, unreadable = 0;
  for (const std::string& stem : expand_stems(a.frames)) {
    Expected<Frame> frame = read_frame(stem);
    if (!frame) {
      spdlog::error("{}", frame.error());
      ++unreadable;
      continue;
    }
    ++frames;
    if (compare_frame(a, stem, *frame, setup, workspace)) ++differing;
  }
  spdlog::info("{} frame(s) compared: {} differ, {} could not be read ({} vs {})", frames, differing,
               unreadable, a.configs[0], a.configs[1]);
  if (unreadable > 0 || frames == 0) return 2;
  return differing == 0 ? 0 : 1;
}

}  // namespace

void register_compare(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "Run two configurations on recorded frames and list every frame whose result differs");
  cmd->add_option("--config", args->configs, "configuration A, then B (give it twice)")
      ->required()
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--recipe", args->recipe, "the recipe whose formats both use (its number in both files)");
  cmd->add_option("--box", args->boxes, "box format LONGxSHORT in mm instead of a recipe (repeat)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_option("--moved-mm", args->moved_mm, "a box counts as moved beyond this centre distance [mm]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--overlay", args->overlay_dir,
                  "write STEM.a.overlay.png and STEM.b.overlay.png of differing frames");
  cmd->add_flag("--json", args->json, "one JSON line per differing frame");
  cmd->add_option("frames", args->frames, "frame stems or folders (the recorder's ring, snapshots)")
      ->required();
  cmd->callback([args] { throw CLI::RuntimeError(run_compare(*args)); });
}

}  // namespace palletd
