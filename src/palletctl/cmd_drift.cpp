// palletctl drift: the camera mount's drift reference, set at commissioning and checked later.
//
//   palletctl drift --config FILE --set [--frame STEM] [--out STEM]
//       makes STEM (or one frame from the configured camera) the reference and writes it to
//       health.drift_reference (or --out); says which motions the cell's fixed parts show
//   palletctl drift --config FILE [--reference STEM] STEM|DIR...
//       measures each frame against the reference: one line per frame; exit 1 when a frame is
//       beyond health.max_drift_mm / _deg, 2 when a frame or the reference cannot be read
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "palletd/config/config.hpp"
#include "palletd/detection/drift.hpp"
#include "palletd/frames/frame_io.hpp"

#include "commands.hpp"
#include "detect_common.hpp"

namespace palletd {

namespace {

struct DriftArgs {
  std::string config;
  bool set = false;
  std::string frame;      // --set: the frame to take instead of a grab
  std::string out;        // --set: where to write it (default health.drift_reference)
  std::string reference;  // check: the reference to compare with (default health.drift_reference)
  std::vector<std::string> stems;
};

[[noreturn]] void fail(int code, const std::string& message) {
  spdlog::error("{}", message);
  throw CLI::RuntimeError(code);
}

Frame read_with_calibration(const std::string& stem, const Config& config) {
  Expected<Frame> frame = read_frame(stem);
  if (!frame) fail(2, stem + ": " + frame.error());
  if (config.T_base_camera) frame->T_base_camera = config.T_base_camera;
  return std::move(frame).value();
}

void run_set(const DriftArgs& args, const Config& config) {
  const std::string out = args.out.empty() ? config.health.drift_reference : args.out;
  if (out.empty()) fail(2, "no place for the reference: set health.drift_reference or pass --out");
  Frame frame;
  if (!args.frame.empty()) {
    frame = read_with_calibration(args.frame, config);
  } else {
    Expected<Frame> grabbed = grab_one_frame(config);
    if (!grabbed) fail(2, "camera: " + grabbed.error());
    frame = std::move(grabbed).value();
  }
  Expected<DriftReference> reference = DriftReference::from_frame(frame, config.detection.roi);
  if (!reference) fail(2, "not a usable reference: " + reference.error());
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(out).parent_path(), ec);
  if (Status written = write_frame(out, frame); !written) fail(2, out + ": " + written.error());
  std::printf("reference %s: %zu fixed points; %s\n", out.c_str(), reference->points(),
              reference->observability().note.c_str());
  std::printf("reload palletd (systemctl reload palletd) to compare every frame with it\n");
}

void run_check(const DriftArgs& args, const Config& config) {
  const std::string stem = args.reference.empty() ? config.health.drift_reference : args.reference;
  if (stem.empty()) fail(2, "no reference: set health.drift_reference or pass --reference");
  Expected<DriftReference> reference =
      DriftReference::from_frame(read_with_calibration(stem, config), config.detection.roi);
  if (!reference) fail(2, "reference " + stem + ": " + reference.error());
  int worst = 0;
  for (const std::string& frame_stem : expand_stems(args.stems)) {
    Expected<Frame> frame = read_frame(frame_stem);
    if (!frame) {
      std::printf("%s: error: %s\n", frame_stem.c_str(), frame.error().c_str());
      worst = 2;
      continue;
    }
    const DriftEstimate d = measure_drift(*frame, *reference);
    if (!d.measured) {
      std::printf("%s: not measured: %s\n", frame_stem.c_str(), d.message.c_str());
      worst = 2;
      continue;
    }
    const bool beyond = d.shift_mm > config.health.max_drift_mm || d.angle_deg > config.health.max_drift_deg;
    if (beyond && worst == 0) worst = 1;
    std::printf("%s: shift %.1f mm, turn %.2f deg (%zu points, rms %.1f mm)%s\n", frame_stem.c_str(),
                d.shift_mm, d.angle_deg, d.points, d.rms_mm, beyond ? ": BEYOND the limits" : "");
  }
  if (worst != 0) throw CLI::RuntimeError(worst);
}

}  // namespace

void register_drift(CLI::App& app) {
  auto args = std::make_shared<DriftArgs>();
  CLI::App* cmd =
      app.add_subcommand("drift", "Set the camera's drift reference, or measure frames against it");
  cmd->add_option("--config", args->config, "configuration (detection.roi, health.drift_reference)")
      ->required();
  cmd->add_flag("--set", args->set, "make a frame the reference (--frame, else one frame from the camera)");
  cmd->add_option("--frame", args->frame, "with --set: the frame stem to take instead of grabbing");
  cmd->add_option("--out", args->out,
                  "with --set: write the reference here instead of health.drift_reference");
  cmd->add_option("--reference", args->reference,
                  "compare with this reference instead of health.drift_reference");
  cmd->add_option("stems", args->stems, "frame stems or folders to measure");
  cmd->callback([args] {
    const Config config = load_config(args->config);
    if (args->set) {
      if (!args->stems.empty()) fail(2, "--set takes --frame, not frame arguments");
      run_set(*args, config);
    } else {
      if (args->stems.empty()) fail(2, "name frames to measure, or --set to make a reference");
      run_check(*args, config);
    }
  });
}

}  // namespace palletd
