// palletctl roi: a region of interest suggested from one frame of the cell, as the YAML snippet
// for the configuration (stdout), a one-line summary (stderr) and optionally a picture.
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "palletd/config/config.hpp"
#include "palletd/detection/roi_suggestion.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/results/overlay_draw.hpp"

#include "commands.hpp"

namespace palletd {

namespace {

struct RoiArgs {
  std::string stem;
  std::string config;
  std::string out_png;
  std::string frame = "base";
  double margin_m = 0.1;
  double above_m = 0.3;
  std::optional<double> max_load_height_m;
  double tall_step_m = 0.4;
};

/// Metres rounded to mm, without a "-0.000".
std::string mm(double value_m) {
  const double rounded = std::round(value_m * 1000.0) / 1000.0;
  char text[32];
  std::snprintf(text, sizeof text, "%.3f", rounded == 0.0 ? 0.0 : rounded);
  return text;
}

std::string roi_yaml(const RegionOfInterest& roi) {
  auto triple = [](const Eigen::Vector3d& v) {
    return "[" + mm(v.x()) + ", " + mm(v.y()) + ", " + mm(v.z()) + "]";
  };
  return std::string("detection:\n  roi:\n    frame: ") +
         (roi.frame == RegionOfInterest::Frame::kBase ? "base" : "camera") +
         "\n    min_m: " + triple(roi.min_m) + "\n    max_m: " + triple(roi.max_m) + "\n";
}

/// The depth in a colour map with the region's edges (yellow) and the footprint's outline at the
/// load's top (white).
void write_picture(const std::string& path, const Frame& frame, const RoiSuggestion& s) {
  const double scale = overlay_scale(frame.intrinsics);
  cv::Mat image = colour_depth_image(frame);
  if (scale > 1.0) cv::resize(image, image, cv::Size(), scale, scale, cv::INTER_NEAREST);
  Frame calibrated = frame;  // draw_region_edges() takes a base-frame region's transform from the frame
  calibrated.T_base_camera = s.T_plan_camera;
  draw_region_edges(image, calibrated, s.roi, scale);
  const Eigen::Isometry3d T_camera_plan = s.T_plan_camera.inverse();
  std::vector<cv::Point> outline;
  for (const Eigen::Vector2d& q : s.footprint_m) {
    const Eigen::Vector3d p = T_camera_plan * Eigen::Vector3d(q.x(), q.y(), s.load_top_z_m);
    if (p.z() < 0.05) continue;  // behind the camera
    const cv::Point2d px = project_to_overlay(frame.intrinsics, p, scale);
    outline.emplace_back(static_cast<int>(std::lround(px.x)), static_cast<int>(std::lround(px.y)));
  }
  if (!outline.empty())
    cv::polylines(image, std::vector<std::vector<cv::Point>>{outline}, true, cv::Scalar(255, 255, 255), 2,
                  cv::LINE_AA);
  if (!cv::imwrite(path, image)) {
    spdlog::error("cannot write {}", path);
    throw CLI::RuntimeError(1);
  }
}

/// camera_to_base and where it came from.
struct Calibration {
  std::optional<Eigen::Isometry3d> T_base_camera;
  bool from_frame = false;  ///< the frame's JSON gave it (the configuration has none)
};

/// camera_to_base from the configuration when it has one, else from the frame's JSON.
Calibration calibration(const RoiArgs& a, const Frame& frame) {
  const Calibration from_frame{frame.T_base_camera, frame.T_base_camera.has_value()};
  if (a.config.empty()) return from_frame;
  try {
    const Config config = load_config(a.config);
    return config.T_base_camera ? Calibration{config.T_base_camera, false} : from_frame;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    throw CLI::RuntimeError(kExitConfigError);
  }
}

int run_roi(const RoiArgs& a) {
  Expected<Frame> frame = read_frame(a.stem);
  if (!frame) {
    spdlog::error("{}", frame.error());
    return 1;
  }
  const Calibration calibrated = calibration(a, *frame);
  RoiSuggestionOptions options;
  options.frame = a.frame == "base" ? RegionOfInterest::Frame::kBase : RegionOfInterest::Frame::kCamera;
  options.margin_m = a.margin_m;
  options.above_m = a.above_m;
  options.max_load_height_m = a.max_load_height_m;
  options.tall_step_m = a.tall_step_m;
  const RoiSuggestion s = suggest_region_of_interest(*frame, calibrated.T_base_camera, options);
  if (!s.ok) {
    spdlog::error("{}: {}", a.stem, s.message);
    return 1;
  }
  if (s.camera_fallback) {
    spdlog::warn("no camera_to_base in {}: the region is given in the camera frame",
                 a.config.empty() ? "the frame's JSON" : a.config + " or the frame's JSON");
  }
  std::printf("%s", roi_yaml(s.roi).c_str());
  if (s.roi.frame == RegionOfInterest::Frame::kBase && calibrated.from_frame)
    std::printf("# the frame's calibration (%s.json): the region's base frame\n%s", a.stem.c_str(),
                camera_to_base_yaml(*calibrated.T_base_camera).c_str());
  std::fflush(stdout);
  spdlog::info("{}", s.message);
  if (!a.out_png.empty()) write_picture(a.out_png, *frame, s);
  return 0;
}

}  // namespace

void register_roi(CLI::App& app) {
  auto args = std::make_shared<RoiArgs>();
  CLI::App* cmd = app.add_subcommand(
      "roi",
      "Suggest detection.roi from one frame of the cell: prints the YAML snippet.\n"
      "The pallet is the blob of what stands on the floor (points > 5 cm above the lowest large height "
      "level)\n"
      "that lies under the optical axis (where it meets the floor), or the blob nearest to that point.\n"
      "Points higher than the stack's top there by more than --tall-step-m are another object (a cabinet\n"
      "touching the pallet) and are left out. The region: the blob's bounding box grown by --margin-m, from\n"
      "the floor + 0.1 m up to the load's top + --above-m (or the floor + --max-load-height-m).\n"
      "A region in the base frame comes with the frame's camera_to_base when --config has none: the\n"
      "snippet is then a configuration of its own (palletctl detect --config).");
  cmd->add_option("frame_stem", args->stem,
                  "frame stem (path without .depth.png), pallet in the middle of the view")
      ->required();
  cmd->add_option("--config", args->config, "palletd configuration: its camera_to_base, else the frame's");
  cmd->add_option("--margin-m", args->margin_m, "grow the footprint by this on every side [m]")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--above-m", args->above_m, "z max = the load's top + this [m]")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option(
         "--max-load-height-m", args->max_load_height_m,
         "z max = the floor + this [m]: the full load's height, when the frame shows a part-picked one")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--tall-step-m", args->tall_step_m,
                  "what stands this much above the stack's top is another object [m]")
      ->check(CLI::PositiveNumber);
  cmd->add_option(
         "--frame", args->frame,
         "frame of the region: base (needs camera_to_base; without it camera, with a warning) or camera")
      ->check(CLI::IsMember({"base", "camera"}));
  cmd->add_option("--out", args->out_png, "write a PNG: depth, the region's edges, the footprint's outline");
  cmd->callback([args] { throw CLI::RuntimeError(run_roi(*args)); });
}

}  // namespace palletd
