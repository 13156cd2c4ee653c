// palletctl eval: detection on every frame of a folder scored against its truth file.
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "detect_common.hpp"
#include "palletd/detection.hpp"
#include "palletd/evaluation.hpp"
#include "palletd/frame_io.hpp"

namespace palletd {

namespace {

struct EvalArgs {
  std::vector<std::string> boxes;
  std::string config;
  int recipe = 0;
  bool json = false;
  bool quiet = false;
  std::vector<std::string> dirs;
};

nlohmann::json to_json(const FrameEval& f) {
  return {{"frame", f.frame},
          {"status", f.status},
          {"ambiguous", f.ambiguous},
          {"truth_boxes", f.truth_boxes},
          {"detected_boxes", f.detected_boxes},
          {"matched", f.matched},
          {"position_error_mm", f.position_errors_mm},
          {"yaw_error_deg", f.yaw_errors_deg},
          {"pairwise_error_mm", f.pairwise_error_mm},
          {"formats_right", f.formats_right},
          {"exact", f.exact},
          {"runtime_ms", f.runtime_ms}};
}

nlohmann::json to_json(const EvalSummary& s) {
  return {{"frames", s.frames},
          {"ok_frames", s.ok_frames},
          {"exact_frames", s.exact_frames},
          {"exact_rate", s.exact_rate},
          {"ambiguous_frames", s.ambiguous_frames},
          {"truth_boxes", s.truth_boxes},
          {"detected_boxes", s.detected_boxes},
          {"matched", s.matched},
          {"precision", s.precision},
          {"recall", s.recall},
          {"position_median_mm", s.position_median_mm},
          {"position_p95_mm", s.position_p95_mm},
          {"position_max_mm", s.position_max_mm},
          {"yaw_median_deg", s.yaw_median_deg},
          {"yaw_p95_deg", s.yaw_p95_deg},
          {"pairwise_mean_mm", s.pairwise_mean_mm},
          {"runtime_median_ms", s.runtime_median_ms},
          {"runtime_p95_ms", s.runtime_p95_ms}};
}

int run_eval(const EvalArgs& a) {
  const DetectSetup setup = make_detect_setup(a.config, a.recipe, a.boxes);
  std::vector<FrameEval> results;
  RayTable rays;
  if (!a.json && !a.quiet) {
    std::printf("%-48s %-9s %5s %5s %5s %8s %8s %8s %5s %8s\n", "frame", "status", "truth", "det", "match", "pos[mm]",
                "yaw[deg]", "pw[mm]", "exact", "ms");
  }
  for (const std::string& stem : expand_stems(a.dirs)) {
    Expected<Truth> truth = read_truth(stem);
    if (!truth) {
      spdlog::warn("{}: no truth, skipped ({})", stem, truth.error());
      continue;
    }
    std::vector<BoxFormat> formats = setup.formats;
    std::vector<std::string> names;
    if (formats.empty()) {
      // The cell's recipe as the truth file lists it (the detector is given these formats).
      for (std::size_t i = 0; i < truth->recipe_mm.size(); ++i) {
        const auto& mm = truth->recipe_mm[i];
        const std::string name = i < truth->recipe.size() ? truth->recipe[i] : std::string();
        formats.push_back(BoxFormat{mm[0] / 1000.0, mm[1] / 1000.0, name});
        names.push_back(name);
      }
    } else {
      for (const auto& f : formats) names.push_back(f.name);
      names.assign(names.size(), std::string());  // --box formats have no truth names to check
    }
    Expected<Frame> frame = read_frame(stem);
    Detection detection;
    if (!frame) {
      detection.status = DetectionStatus::bad_frame;
      detection.message = frame.error();
    } else {
      detection = detect(*frame, formats, setup.params, &rays);
    }
    FrameEval e = evaluate_frame(detection, *truth, names);
    e.frame = stem;
    if (a.json) {
      std::printf("%s\n", to_json(e).dump().c_str());
    } else if (!a.quiet) {
      const double pos = percentile(e.position_errors_mm, 50), yaw = percentile(e.yaw_errors_deg, 50);
      std::printf("%-48s %-9s %5zu %5zu %5zu %8.2f %8.2f %8.2f %5s %8.1f%s\n",
                  std::filesystem::path(stem).filename().string().c_str(), e.status.c_str(), e.truth_boxes,
                  e.detected_boxes, e.matched, pos, yaw, e.pairwise_error_mm, e.exact ? "yes" : "no", e.runtime_ms,
                  e.ambiguous ? "  ambiguous" : "");
    }
    std::fflush(stdout);
    results.push_back(std::move(e));
  }
  const EvalSummary s = summarize(results);
  if (a.json) {
    std::printf("%s\n", nlohmann::json{{"summary", to_json(s)}}.dump().c_str());
  } else {
    std::printf("\nframes %zu (ok %zu, ambiguous %zu) | exact layouts %zu (%.1f %%) | precision %.4f recall %.4f\n",
                s.frames, s.ok_frames, s.ambiguous_frames, s.exact_frames, 100.0 * s.exact_rate, s.precision, s.recall);
    std::printf("position error median %.2f mm, p95 %.2f mm, max %.2f mm | yaw median %.3f deg, p95 %.3f deg\n",
                s.position_median_mm, s.position_p95_mm, s.position_max_mm, s.yaw_median_deg, s.yaw_p95_deg);
    std::printf("pairwise centroid-distance error (paper metric) mean %.2f mm | runtime median %.1f ms, p95 %.1f ms\n",
                s.pairwise_mean_mm, s.runtime_median_ms, s.runtime_p95_ms);
  }
  return results.empty() ? 1 : 0;
}

}  // namespace

void register_eval(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand("eval", "Detect on folders of frames and score against their truth files");
  cmd->add_option("--box", args->boxes, "box formats LONGxSHORT in mm (default: each truth file's recipe)")->expected(1)->take_all();
  cmd->add_option("--config", args->config, "palletd configuration (detection parameters)");
  cmd->add_option("--recipe", args->recipe, "with --config and no --box: the recipe's formats");
  cmd->add_flag("--json", args->json, "one JSON object per frame and a summary object");
  cmd->add_flag("-q,--quiet", args->quiet, "summary only");
  cmd->add_option("dirs", args->dirs, "folders of frames (or frame stems)")->required();
  cmd->callback([args] { throw CLI::RuntimeError(run_eval(*args)); });
}

}  // namespace palletd
