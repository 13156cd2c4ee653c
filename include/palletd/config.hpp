// palletd io: the configuration as plain structs with defaults, parsed at the edge from one
// YAML file (config/palletd.yaml documents every key with its default and unit).
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "palletd/detection.hpp"
#include "palletd/frame.hpp"
#include "palletd/geometry.hpp"

namespace palletd {

struct ReplayCameraConfig {
  std::string directory;   ///< folder of frames in the frame format
  bool loop = true;        ///< start again after the last frame
  double rate_hz = 0.0;    ///< free-running rate; 0 = one frame per trigger
};

struct AravisCameraConfig {
  std::string address;     ///< IP address of the camera (no discovery needed)
  std::string serial;      ///< or its serial number
  std::string user_id;     ///< or its DeviceUserID
  std::string pixel_format = "Coord3D_C16";  ///< Coord3D_C16 | Coord3D_ABC32f | Mono16
  double mono16_scale_m = 0.001;             ///< metres per unit for Mono16 [m]
  int packet_size = 0;         ///< GVSP packet size [bytes]; 0 = negotiate
  bool packet_resend = true;
  int buffer_count = 8;        ///< stream buffer pool
  bool software_trigger = true;  ///< use TriggerSoftware when the camera has it
};

struct OpenNI2CameraConfig {
  std::string uri;         ///< device URI or .oni file; empty = first device
  int width = 640, height = 480, fps = 30;
  double depth_unit_m = 0.001;  ///< 0.001 (1 mm) or 0.0001 (100 um) [m]
  bool ir_as_intensity = true;
  bool loop = true;        ///< .oni recording: start again after the last frame
};

struct CameraConfig {
  std::string driver = "replay";  ///< replay | aravis | openni2
  double frame_timeout_ms = 2000.0;
  double reconnect_min_s = 0.5;   ///< first reconnect delay [s], doubling up to reconnect_max_s
  double reconnect_max_s = 10.0;
  /// A call on the camera's control channel (software trigger, probe) not answered within this
  /// clears CameraOK at once, before the vendor library gives up on the call [ms].
  double control_timeout_ms = 1000.0;
  std::optional<Intrinsics> intrinsics_override;  ///< replaces what the camera reports
  ReplayCameraConfig replay;
  AravisCameraConfig aravis;
  OpenNI2CameraConfig openni2;
};

/// A recipe: a numbered list of box formats the PLC selects.
struct Recipe {
  int number = 0;
  std::string name;
  std::vector<int> formats;  ///< indices into Config::formats
};

struct ModbusConfig {
  std::string bind_address = "127.0.0.1";  ///< never all interfaces by surprise
  int port = 502;
  int unit_id = 1;                  ///< 0 = answer any unit id
  bool low_word_first = false;      ///< 32-bit values: high word first by default
  std::vector<std::string> allow;   ///< addresses / CIDR allowed to connect; empty = any
  std::vector<std::string> read_only;  ///< addresses / CIDR whose writes are refused
  int max_connections = 16;
  double idle_timeout_s = 60.0;     ///< close connections idle this long [s]; 0 = never
  double plc_heartbeat_timeout_s = 0.0;  ///< watch the PLC heartbeat register; 0 = off
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

/// The read-only status page served by the daemon (docs/commissioning.md).
struct WebConfig {
  bool enabled = false;
  std::string bind_address = "127.0.0.1";  ///< loopback by default
  int port = 8080;
  bool allow_snapshot_post = false;  ///< POST /api/snapshot stores the next frame (as SaveSnapshot)
  int refresh_ms = 1000;             ///< page refresh period [ms]
  std::vector<std::string> allowed_hosts;  ///< extra Host names (numeric addresses, localhost always)
};

struct Config {
  std::string source_path;  ///< the file this came from ("" = defaults)
  CameraConfig camera;
  std::optional<Eigen::Isometry3d> T_base_camera;  ///< camera -> robot base (`camera_to_base`)
  std::vector<BoxFormat> formats;
  std::vector<Recipe> recipes;
  DetectionParams detection;
  ModbusConfig modbus;
  PipelineConfig pipeline;
  LoggingConfig logging;
  RecordingConfig recording;
  WebConfig web;
};

/// A configuration error with its place: "FILE:LINE:COLUMN: KEY.PATH: message".
class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, int line, int column, std::string key_path, const std::string& message);
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] int line() const { return line_; }      ///< 1-based, 0 when unknown
  [[nodiscard]] int column() const { return column_; }  ///< 1-based, 0 when unknown
  [[nodiscard]] const std::string& key_path() const { return key_path_; }

 private:
  std::string file_;
  int line_;
  int column_;
  std::string key_path_;
};

/// Loads and validates a configuration file. Throws ConfigError (start-up only).
/// Relative paths in the file (camera.replay.directory, recording.directory) are resolved against
/// the file's folder.
Config load_config(const std::string& path);
/// The same from YAML text; `name` is used in error messages. Relative paths are resolved against
/// `base_directory`, or left as written when it is empty.
Config parse_config(const std::string& yaml_text, const std::string& name,
                    const std::string& base_directory = "");

/// Key paths ("modbus.port", "formats", ...) whose values differ between two configurations
/// (source_path is not compared). Empty when they are equal.
std::vector<std::string> config_differences(const Config& a, const Config& b);
/// Every key path the configuration file accepts, in file order ("camera.driver", ...).
/// `formats`, `recipes`, `camera_to_base` and `camera.intrinsics` are listed as one key each.
std::vector<std::string> config_key_paths();

/// The exit code of `--check-config` on a bad file (sysexits EX_CONFIG).
inline constexpr int kExitConfigError = 78;

}  // namespace palletd
