#include "daemon.hpp"

#include <csignal>
#include <mutex>
#include <cstdlib>

#include <opencv2/core.hpp>
#include <pthread.h>
#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>

#include "palletd/service/service.hpp"
#include "palletd/web/web.hpp"

namespace palletd {

using namespace std::chrono_literals;

void apply_overrides(const DaemonOptions& options, Config& config) {
  if (options.replay_dir) {
    config.camera.driver = "replay";
    config.camera.replay.directory = *options.replay_dir;
    config.camera.replay.rate_hz = 0.0;  // one frame per trigger
    config.camera.replay.loop = true;
  }
  if (options.bind_address) config.modbus.bind_address = *options.bind_address;
  if (options.port) config.modbus.port = static_cast<std::uint16_t>(*options.port);  // 1-65535 (main.cpp)
  if (options.web_port) {
    config.web.enabled = true;
    config.web.server.port = *options.web_port;
  }
}

namespace {

/// The recipes of a configuration with their formats resolved, as the status page shows them.
std::vector<RecipeInfo> recipe_infos(const Config& config) {
  std::vector<RecipeInfo> out;
  for (const auto& r : config.recipes) {
    RecipeInfo info{r.number, r.name, {}};
    for (int index : r.formats)
      if (index >= 0 && static_cast<std::size_t>(index) < config.formats.size())
        info.formats.push_back(config.formats[static_cast<std::size_t>(index)]);
    out.push_back(std::move(info));
  }
  return out;
}

void notify(const std::string& message) { (void)sd_notify(0, message.c_str()); }

}  // namespace

int run_daemon(const DaemonOptions& options, Config config) {
  // Signals are taken synchronously by this thread: block them before any thread starts so every
  // thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  // Detection runs on the pipeline thread alone (one core per detection, as benchmarked): no
  // OpenCV worker pool behind it.
  cv::setNumThreads(0);
  apply_overrides(options, config);
  Service service(config);
  Status started = service.start();
  if (!started) {
    spdlog::critical("palletd cannot start: {}", started.error());
    notify("STATUS=cannot start: " + started.error());
    return 1;
  }
  // The status page, bound before READY=1 like the Modbus port.
  std::mutex recipes_mutex;
  std::vector<RecipeInfo> recipes = recipe_infos(config);
  std::unique_ptr<WebServer> web;
  if (config.web.enabled) {
    WebOptions wo = config.web.server;
    wo.log = [](const std::string& line) { spdlog::info("web: {}", line); };
    StatusSource source;
    source.latest = [&service] { return service.latest(); };
    source.health = [&service] { return service.health(); };
    source.registers = [&service] { return service.registers(); };
    source.recipes = [&] {
      std::lock_guard<std::mutex> lock(recipes_mutex);
      return recipes;
    };
    source.request_snapshot = [&service] { return service.request_snapshot(); };
    source.word_order = config.modbus.handshake.word_order;
    web = std::make_unique<WebServer>(wo, source);
    if (Status s = web->start(); !s) {
      spdlog::critical("palletd cannot start: {}", s.error());
      notify("STATUS=cannot start: " + s.error());
      service.stop();
      return 1;
    }
    spdlog::info("status page on http://{}:{}/", wo.bind_address, web->port());
  }

  std::uint64_t watchdog_us = 0;
  const bool watchdog = sd_watchdog_enabled(0, &watchdog_us) > 0 && watchdog_us > 0;
  const auto watchdog_period = std::chrono::microseconds(watchdog_us / 2);
  notify("READY=1\nSTATUS=" + service.status_line());
  spdlog::info("palletd ready: {}", service.status_line());

  auto last_watchdog = std::chrono::steady_clock::now();
  auto last_status = last_watchdog;
  for (;;) {
    const timespec wait{0, 200'000'000};  // 200 ms
    const int sig = sigtimedwait(&signals, nullptr, &wait);
    if (sig == SIGTERM || sig == SIGINT) {
      spdlog::info("palletd stopping ({})", sig == SIGTERM ? "SIGTERM" : "SIGINT");
      break;
    }
    if (sig == SIGHUP) {
      notify("RELOADING=1");
      try {
        Config next = load_config(options.config_path);
        apply_overrides(options, next);
        service.reload(next);
        {
          std::lock_guard<std::mutex> lock(recipes_mutex);
          recipes = recipe_infos(next);
        }
        spdlog::info("configuration reloaded from {}", options.config_path);
      } catch (const std::exception& e) {
        // The old configuration stays in force.
        spdlog::error("reload refused, keeping the running configuration: {}", e.what());
        notify("STATUS=reload refused: " + std::string(e.what()));
      }
      notify("READY=1");
    }
    const auto now = std::chrono::steady_clock::now();
    if (watchdog && now - last_watchdog >= watchdog_period && service.health().threads_alive) {
      notify("WATCHDOG=1");
      last_watchdog = now;
    }
    if (now - last_status >= 2s) {
      notify("STATUS=" + service.status_line());
      last_status = now;
    }
  }
  notify("STOPPING=1");
  if (web) web->stop();
  service.stop();
  spdlog::info("palletd stopped");
  return 0;
}

}  // namespace palletd
