// Shared by `palletctl detect`, `eval` and `compare`: box formats from --box / config, frame stems,
// writing output files.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "palletd/config/config.hpp"
#include "palletd/core/expected.hpp"
#include "palletd/core/geometry.hpp"

namespace palletd {

/// "315x232" -> {0.315, 0.232, "315x232"} (long side first; sizes in mm).
Expected<BoxFormat> parse_box_arg(const std::string& text);

/// Expands arguments that name folders into the frame stems they hold (name order); other
/// arguments are taken as stems as they are.
std::vector<std::string> expand_stems(const std::vector<std::string>& args);

/// Detection parameters and formats from --config / --recipe / --box. Throws CLI::RuntimeError
/// with a logged message when they do not fit together.
struct DetectSetup {
  DetectionParams params;
  std::vector<BoxFormat> formats;  ///< empty: take the truth file's recipe (eval only)
  std::optional<Eigen::Isometry3d> T_base_camera;  ///< from the config, when it has one
  /// The config's recipes other than --recipe: where a frame's cartons disagree with the
  /// formats (recipe_mismatch), the one that fits best is named (as the daemon does).
  std::vector<RecipeCandidate> other_recipes;
  /// --recipe names a size-range recipe: cartons nobody entered, sizes measured on each frame.
  std::optional<SizeRange> size_range;
};
DetectSetup make_detect_setup(const std::string& config_path, int recipe, const std::vector<std::string>& boxes);

/// detect() with `formats`, or detect_unknown_cartons() with the setup's size range.
Detection detect_with_setup(const Frame& frame, const DetectSetup& setup, const std::vector<BoxFormat>& formats,
                            const DetectionParams& params, DetectionWorkspace& workspace);

/// name_recipe_shown() with setup.other_recipes: after a recipe mismatch or a layer the recipe
/// cannot lay out, which other recipe the frame shows.
void name_best_recipe(const Frame& frame, const DetectSetup& setup, const DetectionParams& params,
                      DetectionWorkspace& workspace, Detection& detection);

/// Writes `bytes` to `path` (an overlay, a debug picture); logs when it cannot.
void write_bytes(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes);

}  // namespace palletd
