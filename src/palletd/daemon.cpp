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
  if (options.port) config.modbus.port = *options.port;
  if (options.web_port) {
    config.web.enabled = true;
    config.web.port = *options.web_port;
  }
}

namespace {

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
    WebOptions wo;
    wo.bind_address = config.web.bind_address;
    wo.port = config.web.port;
    wo.allow_snapshot_post = config.web.allow_snapshot_post;
    wo.refresh_ms = config.web.refresh_ms;
    wo.allowed_hosts = config.web.allowed_hosts;
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
    source.word_order = config.modbus.low_word_first ? modbus::WordOrder::kLowWordFirst : modbus::WordOrder::kHighWordFirst;
    web = std::make_unique<WebServer>(wo, source);
    if (Status s = web->start(); !s) {
      spdlog::critical("palletd cannot start: {}", s.error());
      notify("STATUS=cannot start: " + s.error());
      service.stop();
      return 1;
    }
    spdlog::info("status page on http://{}:{}/", config.web.bind_address, web->port());
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
