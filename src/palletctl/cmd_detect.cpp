// palletctl detect: frames in, one JSON line per frame out (shared/spec/detections.md).
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "detect_common.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/results/detection_json.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/detection/layer_debug.hpp"
#include "palletd/results/overlay.hpp"

namespace palletd {

namespace {

struct DetectArgs {
  std::vector<std::string> boxes;
  std::string config;
  int recipe = 0;
  std::string overlay_dir;
  std::string debug_dir;
  std::vector<std::string> frames;
};

Detection bad_frame(const std::string& message) {
  Detection d;
  d.status = DetectionStatus::kBadFrame;
  d.message = message;
  d.timing_ms["total"] = 0.0;
  return d;
}

int run_detect(const DetectArgs& a) {
  DetectSetup setup = make_detect_setup(a.config, a.recipe, a.boxes);
  if (setup.formats.empty() && !setup.size_range) {
    spdlog::error("no box format: give --box LxW (mm) or --config FILE --recipe N");
    return 2;
  }
  for (const auto* dir : {&a.overlay_dir, &a.debug_dir}) {
    if (!dir->empty()) std::filesystem::create_directories(*dir);
  }
  DetectionWorkspace workspace;  // rays and cloud reused from frame to frame
  int failed = 0;
  for (const std::string& stem : expand_stems(a.frames)) {
    Expected<Frame> frame = read_frame(stem);
    Detection detection;
    if (!frame) {
      detection = bad_frame(frame.error());
    } else {
      if (setup.T_base_camera) frame->T_base_camera = setup.T_base_camera;
      detection = detect_with_setup(*frame, setup, setup.formats, setup.params, workspace);
      name_best_recipe(*frame, setup, setup.params, workspace, detection);
    }
    std::printf("%s\n", detection_to_json_line(detection, stem).c_str());
    std::fflush(stdout);
    if (is_failure(detection.status)) ++failed;
    if (!frame) continue;
    const std::string name = std::filesystem::path(stem).filename().string();
    if (!a.overlay_dir.empty())
      write_bytes(std::filesystem::path(a.overlay_dir) / (name + ".overlay.png"), render_overlay_png(*frame, detection));
    // A frame detect() could not read or cut to the region left no cloud of its own.
    if (!a.debug_dir.empty() && detection.status != DetectionStatus::kBadFrame) {
      // Re-run the first half with a trace (detect() keeps no intermediate images) on the cloud
      // detect() left in the workspace: cut to the region of interest, as the detection saw it.
      double smallest_m2 = setup.size_range ? setup.size_range->long_min_m * setup.size_range->short_min_m : 1e9;
      for (const auto& f : setup.formats) smallest_m2 = std::min(smallest_m2, f.long_m * f.short_m);
      const double min_piece_m2 = setup.params.layer.min_component_box_fraction * smallest_m2;
      PlaneParams plane = setup.params.plane;  // the top level holds a piece of a box (detect())
      plane.min_plane_area_m2 = std::max(plane.min_plane_area_m2, min_piece_m2);
      LayerTrace trace;
      const LayerResult layer = extract_layer(*frame, workspace.cloud, plane, setup.params.layer,
                                              setup.params.contour, min_piece_m2, &trace);
      for (const auto& image : render_layer_debug_images(*frame, layer, trace)) {
        cv::imwrite((std::filesystem::path(a.debug_dir) / (name + "." + image.first + ".png")).string(), image.second);
      }
    }
  }
  return failed == 0 ? 0 : 1;
}

}  // namespace

void register_detect(CLI::App& app) {
  auto args = std::make_shared<DetectArgs>();
  CLI::App* cmd = app.add_subcommand("detect", "Detect the top layer's boxes in frames; one JSON line per frame");
  cmd->add_option("--box", args->boxes, "box format LONGxSHORT in mm (repeat; numbered 0, 1, ... in order)")->expected(1)->take_all();
  cmd->add_option("--config", args->config,
                  "palletd configuration: the detection parameters (detection.roi included) and the gripper "
                  "(pickable, blocked_by, tcp and groups in the JSON) come from it, the formats from --box (else from "
                  "--recipe N); camera_to_base from it, else from each frame's JSON");
  cmd->add_option("--recipe", args->recipe, "with --config and no --box: the recipe's formats");
  cmd->add_option("--overlay", args->overlay_dir, "write STEM.overlay.png per frame into DIR");
  cmd->add_option("--debug-dir", args->debug_dir, "write one PNG per detection stage and frame into DIR");
  cmd->add_option("frames", args->frames, "frame stems (path without .depth.png) or folders of frames")->required();
  cmd->callback([args] { throw CLI::RuntimeError(run_detect(*args)); });
}

}  // namespace palletd
