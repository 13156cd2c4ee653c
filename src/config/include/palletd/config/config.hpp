// palletd config: the configuration as plain structs with defaults, parsed at the edge from one
// YAML file (config/palletd.yaml documents every key with its default and unit).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "palletd/config_table/table.hpp"
#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/pick_check.hpp"
#include "palletd/detection/recipe_choice.hpp"
#include "palletd/detection/unknown_cartons.hpp"
#include "palletd/drivers/camera_config.hpp"
#include "palletd/modbus/server.hpp"
#include "palletd/web/web.hpp"

namespace palletd {

/// A recipe: a numbered list of box formats the PLC selects, or a size range.
struct Recipe {
  int number = 0;
  std::string name;
  std::vector<int> formats;  ///< indices into Config::formats
  /// Cartons nobody entered (`size_range_mm`): the sizes are measured on the frame
  /// (detect_unknown_cartons()); `formats` is then empty.
  std::optional<SizeRange> size_range;
};

struct PipelineConfig {
  double detection_timeout_ms = 2000.0;  ///< a detection longer than this is reported as failed
  int default_recipe = 1;
};

struct LoggingConfig {
  std::string level = "info";  ///< trace | debug | info | warn | error
};

struct RecordingConfig {
  bool enabled = false;
  std::string directory = "/var/lib/palletd/recordings";
  std::uint64_t max_bytes = 2ull << 30;  ///< ring size on disk [bytes]
  bool every_trigger = false;   ///< record each triggered frame (else only on SaveSnapshot)
  bool overlays = true;
};

/// `health`: the cell's health over a rolling window of triggered frames, and camera mount drift
/// against a reference frame (docs/commissioning.md, "Cell health and drift").
struct HealthConfig {
  int window_frames = 20;               ///< triggered frames the limits are checked over (mean)
  double max_invalid_fraction = 0.25;   ///< pixels without depth, of the region of interest's
  double max_flying_fraction = 0.0;     ///< mixed pixels, of those just outside the layer (0: not checked)
  double max_saturated_fraction = 0.02; ///< saturated pixels, of the region of interest's
  double max_noise_ratio = 2.0;         ///< layer plane noise over the noise model's
  DepthNoiseModel noise_model;          ///< copied into DetectionParams::noise_model
  /// Stem of the reference frame (STEM.depth.png + STEM.json) drift is measured against; written
  /// by `palletctl drift-reference` and by control bit 4. "" = no drift check.
  std::string drift_reference = "/var/lib/palletd/drift-reference";
  double max_drift_mm = 10.0;  ///< camera shift against the reference that raises DriftWarning [mm]
  double max_drift_deg = 0.3;  ///< camera turn against the reference that raises DriftWarning [deg]
};

struct Config {
  std::string source_path;  ///< the file this came from ("" = defaults)
  CameraConfig camera;
  std::optional<Eigen::Isometry3d> T_base_camera;  ///< camera -> robot base (`camera_to_base`)
  std::vector<BoxFormat> formats;
  std::vector<Recipe> recipes;
  DetectionParams detection;
  modbus::ServerOptions modbus;  ///< the server as configured; the service adds its log sink and initial recipe
  PipelineConfig pipeline;
  LoggingConfig logging;
  RecordingConfig recording;
  WebConfig web;
  MetricsConfig metrics;
  HealthConfig health;
  PickCheckParams check;  ///< `check`: what the check after a pick counts as a moved box
  /// `shadow_config`: a second configuration the daemon runs on every triggered frame after the
  /// live result, to count where it would differ (its detection, formats, recipes and
  /// camera_to_base are used). The resolved path ("" = none) and the file as loaded.
  std::string shadow_config;
  std::shared_ptr<const Config> shadow;
};

/// Where the camera's calibration comes from. The daemon has only its configuration's
/// camera_to_base: a base-frame region or pallet height without it is a configuration error.
/// Offline tools (palletctl detect, eval, compare) fall back on each frame's JSON, and a frame
/// that has none fails on its own with the reason.
enum class CalibrationSource { kConfiguration, kConfigurationOrFrames };

/// Loads and validates a configuration file. Throws ConfigError (start-up only).
/// Relative paths in the file (camera.replay.directory, recording.directory) are resolved against
/// the file's folder.
Config load_config(const std::string& path,
                   CalibrationSource calibration = CalibrationSource::kConfiguration);
/// The same from YAML text; `name` is used in error messages. Relative paths are resolved against
/// `base_directory`, or left as written when it is empty.
Config parse_config(const std::string& yaml_text, const std::string& name,
                    const std::string& base_directory = "",
                    CalibrationSource calibration = CalibrationSource::kConfiguration);

/// The cell settings a file beside a frame may carry (STEM.roi.yaml, as the simulator and
/// `palletctl roi` write it): `detection.roi` and `pallet`, in the configuration's syntax. A
/// base-frame region needs the frame's camera_to_base (not checked here). Throws ConfigError.
struct CellFile {
  std::optional<RegionOfInterest> roi;
  PalletParams pallet;
};
CellFile load_cell_file(const std::string& path);

/// The recipes as best_fitting_recipe() takes them (their formats resolved), all but the one
/// numbered `except`.
std::vector<RecipeCandidate> recipe_candidates(const Config& config, int except);

/// Key paths ("modbus.port", "formats", ...) whose values differ between two configurations
/// (source_path is not compared). Empty when they are equal.
std::vector<std::string> config_differences(const Config& a, const Config& b);
/// Every key path the configuration file accepts, in file order ("camera.driver", ...).
/// `formats`, `recipes`, `camera_to_base` and `camera.intrinsics` are listed as one key each.
std::vector<std::string> config_key_paths();

/// The exit code of `--check-config` on a bad file (sysexits EX_CONFIG).
inline constexpr int kExitConfigError = 78;

}  // namespace palletd
