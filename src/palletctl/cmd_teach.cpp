// palletctl teach: the cartons of a frame measured without a recipe, printed as config entries
// to paste (a format per size and a recipe), and drawn.
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "palletd/detection/unknown_cartons.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/results/overlay.hpp"
#include "palletd/results/teach.hpp"

#include "commands.hpp"
#include "detect_common.hpp"

namespace palletd {

namespace {

struct TeachArgs {
  std::string frame;
  std::string config;
  std::vector<double> long_mm = {150.0, 1000.0};
  std::vector<double> short_mm = {100.0, 800.0};
  int number = 1;
  std::string name;
  std::string overlay;
};

int run_teach(const TeachArgs& a) {
  const DetectSetup setup = make_detect_setup(a.config, 0, {});
  Expected<Frame> frame = read_frame(a.frame);
  if (!frame) {
    spdlog::error("{}", frame.error());
    return 2;
  }
  if (setup.T_base_camera) frame->T_base_camera = setup.T_base_camera;
  const SizeRange range{1e-3 * a.long_mm[0], 1e-3 * a.long_mm[1], 1e-3 * a.short_mm[0], 1e-3 * a.short_mm[1]};
  DetectionWorkspace workspace;
  const Detection detection = detect_unknown_cartons(*frame, range, setup.params, workspace);
  if (!a.overlay.empty()) write_bytes(a.overlay, render_overlay_png(*frame, detection));
  const Teaching teaching = teach_from(detection);
  if (teaching.formats.empty()) {
    std::printf("# %s: nothing measured: %s\n", a.frame.c_str(), teaching.reason.c_str());
    return 1;
  }
  for (const TaughtFormat& f : teaching.formats)
    std::printf("# %d carton(s) of %d x %d mm (spread %.1f mm)\n", f.boxes, f.long_mm, f.short_mm,
                f.spread_mm);
  if (!teaching.taught)
    std::printf("# NOT SETTLED: %s\n# check the sizes by hand before you use them\n",
                teaching.reason.c_str());
  std::printf("%s",
              recipe_yaml(teaching, a.number, a.name.empty() ? "taught from " + a.frame : a.name).c_str());
  return teaching.taught ? 0 : 1;
}

}  // namespace

void register_teach(CLI::App& app) {
  auto args = std::make_shared<TeachArgs>();
  CLI::App* cmd = app.add_subcommand(
      "teach", "Measure the cartons of a frame without a recipe; print a format and a recipe entry to paste");
  cmd->add_option("frame", args->frame, "frame stem (path without .depth.png)")->required();
  cmd->add_option("--config", args->config,
                  "palletd configuration: detection parameters, region, camera_to_base");
  cmd->add_option("--long-mm", args->long_mm, "the long side's range MIN MAX [mm]")
      ->expected(2)
      ->capture_default_str();
  cmd->add_option("--short-mm", args->short_mm, "the short side's range MIN MAX [mm]")
      ->expected(2)
      ->capture_default_str();
  cmd->add_option("--number", args->number, "recipe number of the entry printed")
      ->check(CLI::Range(1, 65535));
  cmd->add_option("--name", args->name, "recipe name of the entry printed (default: taught from STEM)");
  cmd->add_option("--overlay", args->overlay, "write the boxes measured over the frame to this PNG");
  cmd->callback([args] { throw CLI::RuntimeError(run_teach(*args)); });
}

}  // namespace palletd
