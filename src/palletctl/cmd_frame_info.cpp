// palletctl info STEM...: a one-line summary per frame file set.
#include <algorithm>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "palletd/frames/frame_io.hpp"

namespace palletd {

namespace {

/// "640x480, depth_scale 0.001 m, valid 93.2 %, depth 0.812..1.503 m, intensity 16-bit, camera X"
std::string summary(const Frame& frame) {
  std::uint16_t lo = std::numeric_limits<std::uint16_t>::max();
  std::uint16_t hi = 0;
  std::size_t valid = 0;
  for (const std::uint16_t d : frame.depth) {
    if (d == 0) continue;
    ++valid;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  const double share = frame.depth.empty() ? 0.0 : 100.0 * static_cast<double>(valid) / static_cast<double>(frame.depth.size());
  char text[512];
  std::snprintf(text, sizeof text, "%dx%d, depth_scale %g m, valid %.1f %%, ", frame.intrinsics.width,
                frame.intrinsics.height, frame.depth_scale_m, share);
  std::string line = text;
  if (valid > 0) {
    std::snprintf(text, sizeof text, "depth %.3f..%.3f m", lo * frame.depth_scale_m, hi * frame.depth_scale_m);
    line += text;
  } else {
    line += "depth -";
  }
  line += frame.has_intensity() ? ", intensity " + std::to_string(frame.intensity_bits) + "-bit" : ", intensity none";
  if (frame.intrinsics.distortion) line += ", distorted";
  if (frame.T_base_camera) line += ", camera_to_base";
  line += ", camera " + (frame.camera_id.empty() ? std::string("-") : frame.camera_id);
  return line;
}

}  // namespace

void register_frame_info(CLI::App& app) {
  auto* cmd = app.add_subcommand("info", "Print a one-line summary of each frame (size, depth scale, valid "
                                         "pixels, depth range, intensity, camera)");
  auto stems = std::make_shared<std::vector<std::string>>();
  cmd->add_option("stems", *stems, "frame stems (paths without .depth.png)")->required();
  cmd->callback([stems] {
    int failed = 0;
    for (const std::string& stem : *stems) {
      spdlog::debug("reading {}", stem);
      auto frame = read_frame(stem);
      if (!frame) {
        std::printf("%s: error: %s\n", stem.c_str(), frame.error().c_str());
        ++failed;
      } else {
        std::printf("%s: %s\n", stem.c_str(), summary(*frame).c_str());
      }
    }
    std::fflush(stdout);
    if (failed > 0) {
      spdlog::warn("{} of {} frame(s) could not be read", failed, stems->size());
      throw CLI::RuntimeError(1);
    }
  });
}

}  // namespace palletd
