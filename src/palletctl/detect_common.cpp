#include "detect_common.hpp"

#include <filesystem>
#include <fstream>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "palletd/frames/frame_io.hpp"

namespace palletd {

Expected<BoxFormat> parse_box_arg(const std::string& text) {
  const auto x = text.find_first_of("xX");
  if (x == std::string::npos) return Error{"--box " + text + ": expected LONGxSHORT in mm, e.g. 315x232"};
  try {
    std::size_t used_a = 0, used_b = 0;
    const double a = std::stod(text.substr(0, x), &used_a);
    const double b = std::stod(text.substr(x + 1), &used_b);
    if (used_a != x || used_b != text.size() - x - 1) throw std::invalid_argument("trailing text");
    if (!(a > 0.0) || !(b > 0.0)) return Error{"--box " + text + ": sizes must be positive"};
    if (b > a) return Error{"--box " + text + ": give the long side first"};
    return BoxFormat{a / 1000.0, b / 1000.0, text};
  } catch (const std::exception&) {
    return Error{"--box " + text + ": expected LONGxSHORT in mm, e.g. 315x232"};
  }
}

std::vector<std::string> expand_stems(const std::vector<std::string>& args) {
  std::vector<std::string> stems;
  for (const auto& a : args) {
    std::error_code ec;
    if (std::filesystem::is_directory(a, ec)) {
      auto listed = list_frame_stems(a);
      if (listed) stems.insert(stems.end(), listed->begin(), listed->end());
      else spdlog::error("{}", listed.error());
      continue;
    }
    std::string stem = a;
    const std::string suffix = ".depth.png";
    if (stem.size() > suffix.size() && stem.compare(stem.size() - suffix.size(), suffix.size(), suffix) == 0)
      stem.resize(stem.size() - suffix.size());
    stems.push_back(stem);
  }
  return stems;
}

DetectSetup make_detect_setup(const std::string& config_path, int recipe, const std::vector<std::string>& boxes) {
  DetectSetup setup;
  Config config;
  if (!config_path.empty()) {
    try {
      config = load_config(config_path, CalibrationSource::kConfigurationOrFrames);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      throw CLI::RuntimeError(kExitConfigError);
    }
    setup.params = config.detection;
    setup.T_base_camera = config.T_base_camera;
    setup.other_recipes = recipe_candidates(config, boxes.empty() ? recipe : 0);
  }
  for (const auto& b : boxes) {
    auto f = parse_box_arg(b);
    if (!f) {
      spdlog::error("{}", f.error());
      throw CLI::RuntimeError(2);
    }
    setup.formats.push_back(*f);
  }
  if (setup.formats.empty() && recipe > 0) {
    for (const auto& r : config.recipes) {
      if (r.number != recipe) continue;
      setup.size_range = r.size_range;
      for (int i : r.formats) setup.formats.push_back(config.formats[static_cast<std::size_t>(i)]);
    }
    if (setup.formats.empty() && !setup.size_range) {
      spdlog::error("recipe {} is not in {}", recipe, config_path.empty() ? "(no --config)" : config_path);
      throw CLI::RuntimeError(2);
    }
  }
  return setup;
}

Detection detect_with_setup(const Frame& frame, const DetectSetup& setup, const std::vector<BoxFormat>& formats,
                            const DetectionParams& params, DetectionWorkspace& workspace) {
  if (setup.size_range && setup.formats.empty()) return detect_unknown_cartons(frame, *setup.size_range, params, workspace);
  return detect(frame, formats, params, workspace);
}

void name_best_recipe(const Frame& frame, const DetectSetup& setup, const DetectionParams& params,
                      DetectionWorkspace& workspace, Detection& detection) {
  name_recipe_shown(frame, setup.other_recipes, params, workspace, detection);
}

void write_bytes(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) spdlog::error("cannot write {}", path.string());
}

}  // namespace palletd
