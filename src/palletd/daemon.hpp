// palletd daemon: runs the Service under systemd (or in a terminal) until SIGTERM/SIGINT.
//
// sd_notify protocol (Type=notify): READY=1 once the config is loaded and the Modbus port is
// bound; STATUS= with a readable state every few seconds; WATCHDOG=1 at half the watchdog
// interval, and only while every service thread is alive; RELOADING=1 / READY=1 around a SIGHUP
// reload; STOPPING=1 on the way out. Without NOTIFY_SOCKET these are no-ops.
#pragma once

#include <string>

#include "palletd/config/config.hpp"

namespace palletd {

struct DaemonOptions {
  std::string config_path;  ///< reloaded on SIGHUP (recipes, formats, detection parameters)
  /// Applied to the loaded config at start and after every reload.
  std::optional<std::string> replay_dir;
  std::optional<std::string> bind_address;
  std::optional<int> port;
  std::optional<int> web_port;  ///< serve the status page on this port (enables it)
  std::optional<int> metrics_port;  ///< serve /metrics on this port (enables the metrics server)
};

/// Applies the command-line overrides to a loaded config.
void apply_overrides(const DaemonOptions& options, Config& config);

/// FNV-1a 64 of the file's bytes in hex (the `palletd_config_info` metric); "" when unreadable.
std::string config_file_hash(const std::string& path);

/// Runs until SIGTERM or SIGINT. Returns the process exit code (0 on a clean stop, 1 when the
/// service could not start, e.g. the port is taken).
int run_daemon(const DaemonOptions& options, Config config);

}  // namespace palletd
