// palletctl: the command-line tool for frames, detection, evaluation and the PLC side.
// Data goes to stdout, logs to stderr.
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.hpp"

int main(int argc, char** argv) {
  cv::setNumThreads(0);  // one core per detection, as in the daemon
  auto logger = spdlog::stderr_color_mt("palletctl");
  logger->set_pattern("%^%l%$: %v");
  spdlog::set_default_logger(logger);

  CLI::App app{"palletctl: work with palletd frames, detections and the PLC interface", "palletctl"};
  app.set_version_flag("--version", std::string("palletctl ") + PALLETD_VERSION);
  app.option_defaults()->always_capture_default();
  app.fallthrough();  // global options may follow the subcommand
  app.add_option("--log-level", "log level on stderr: trace, debug, info, warn, error, off")
      ->default_str("info")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}))
      ->each([](const std::string& level) { spdlog::set_level(spdlog::level::from_str(level)); });
  app.require_subcommand(1);

  palletd::register_frame_info(app);
  palletd::register_watch(app);
  palletd::register_calibrate(app);
  palletd::register_trigger(app);
  palletd::register_detect(app);
  palletd::register_eval(app);
  palletd::register_simulate(app);
  palletd::register_roi(app);
  palletd::register_compare(app);
  palletd::register_drift(app);
  palletd::register_teach(app);
  palletd::register_grab(app);
  palletd::register_record(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::Error& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
