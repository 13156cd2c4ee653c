// palletd: the daemon. Loads and validates the configuration, then runs the service.
//   palletd --config FILE          run (default FILE: the installed /etc/palletd/palletd.yaml)
//   palletd --check-config FILE    validate only: "FILE: ok" (warnings on stderr) and exit 0, or the
//                                  error and exit 78
//   overrides for testing: --replay DIR (replay driver, one frame per trigger, looping),
//   --bind ADDR, --port N, --web-port N, --metrics-port N
#include <iostream>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "palletd/config/config.hpp"
#include "palletd/config/config_warnings.hpp"

#include "service_entry.hpp"

namespace {

/// Loads the file; on error prints "FILE:LINE:COLUMN: key.path: message" and returns nullopt.
std::optional<palletd::Config> load_or_report(const std::string& path) {
  try {
    return palletd::load_config(path);
  } catch (const palletd::ConfigError& e) {
    std::cerr << e.what() << "\n";
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"palletd: finds the top layer of a box pallet and serves the box poses over Modbus TCP",
               "palletd"};
  app.set_version_flag("--version", std::string("palletd ") + PALLETD_VERSION);
  std::string config_path = PALLETD_DEFAULT_CONFIG;
  std::string check_path;
  auto* check = app.add_option("--check-config", check_path,
                               "validate FILE and exit: 0 when valid, 78 (EX_CONFIG) with the error");
  app.add_option("--config", config_path, "configuration file to run with")
      ->capture_default_str()
      ->excludes(check);
  std::string replay_dir, bind_address;
  int port = 0;
  auto* replay = app.add_option("--replay", replay_dir,
                                "replay the frames in DIR (one per trigger, looping) instead of the camera")
                     ->check(CLI::ExistingDirectory);
  auto* bind = app.add_option("--bind", bind_address, "Modbus TCP bind address (overrides modbus.bind_address)");
  auto* port_opt = app.add_option("--port", port, "Modbus TCP port (overrides modbus.port)")
                       ->check(CLI::Range(1, 65535));
  int web_port = 0;
  auto* web_opt = app.add_option("--web-port", web_port, "serve the status page on this port (overrides web.*)")
                      ->check(CLI::Range(1, 65535));
  int metrics_port = 0;
  auto* metrics_opt =
      app.add_option("--metrics-port", metrics_port, "serve /metrics on this port (overrides metrics.*)")
          ->check(CLI::Range(1, 65535));
  try {
    app.parse(argc, argv);
  } catch (const CLI::Error& e) {
    return app.exit(e);
  }

  if (!check_path.empty()) {
    const auto checked = load_or_report(check_path);
    if (!checked) return palletd::kExitConfigError;
    for (const std::string& w : palletd::config_warnings(*checked))
      std::cerr << check_path << ": warning: " << w << "\n";
    std::cout << check_path << ": ok\n";
    return 0;
  }
  auto config = load_or_report(config_path);
  if (!config) return palletd::kExitConfigError;
  palletd::DaemonOptions options;
  options.config_path = config_path;
  if (replay->count() > 0) options.replay_dir = replay_dir;
  if (bind->count() > 0) options.bind_address = bind_address;
  if (port_opt->count() > 0) options.port = port;
  if (web_opt->count() > 0) options.web_port = web_port;
  if (metrics_opt->count() > 0) options.metrics_port = metrics_port;
  return palletd::start_service(options, std::move(*config));
}
