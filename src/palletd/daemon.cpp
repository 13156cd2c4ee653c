#include "daemon.hpp"

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <mutex>

#include <opencv2/core.hpp>
#include <pthread.h>
#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>

#include "palletd/config/config_warnings.hpp"
#include "palletd/metrics/metrics.hpp"
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
  if (options.metrics_port) {
    config.metrics.enabled = true;
    config.metrics.server.port = *options.metrics_port;
  }
}

std::string config_file_hash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::uint64_t hash = 14695981039346656037ull;  // FNV-1a 64
  for (std::istreambuf_iterator<char> it(in), end; it != end; ++it) {
    hash ^= static_cast<unsigned char>(*it);
    hash *= 1099511628211ull;
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return text;
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

/// Starts one HTTP server (the status page or the metrics) on `source`; null with the reason
/// logged and notified when it cannot bind.
std::unique_ptr<WebServer> start_http(WebOptions options, const StatusSource& source, const char* what) {
  options.log = [what](const std::string& line) { spdlog::info("{}: {}", what, line); };
  auto server = std::make_unique<WebServer>(options, source);
  if (Status s = server->start(); !s) {
    spdlog::critical("palletd cannot start: {}", s.error());
    notify("STATUS=cannot start: " + s.error());
    return nullptr;
  }
  return server;
}

/// What the HTTP threads read besides the service: the recipes and the configuration file's hash,
/// replaced by a reload.
struct DaemonInfo {
  std::mutex mutex;
  std::vector<RecipeInfo> recipes;
  std::string config_hash;

  void update(const Config& config, const std::string& path) {
    std::vector<RecipeInfo> next = recipe_infos(config);
    std::string hash = config_file_hash(path);
    std::lock_guard<std::mutex> lock(mutex);
    recipes = std::move(next);
    config_hash = std::move(hash);
  }
};

MetricsSource metrics_source(Service& service, DaemonInfo& info) {
  MetricsSource source;
  source.health = [&service] { return service.health(); };
  source.modbus = [&service] { return service.modbus_stats(); };
  source.config_hash = [&info] {
    std::lock_guard<std::mutex> lock(info.mutex);
    return info.config_hash;
  };
  return source;
}

StatusSource status_source(Service& service, DaemonInfo& info, Metrics& metrics, modbus::WordOrder order) {
  StatusSource source;
  source.latest = [&service] { return service.latest(); };
  source.health = [&service] { return service.health(); };
  source.registers = [&service] { return service.registers(); };
  source.recipes = [&info] {
    std::lock_guard<std::mutex> lock(info.mutex);
    return info.recipes;
  };
  source.request_snapshot = [&service] { return service.request_snapshot(); };
  source.word_order = order;
  source.metrics = [&metrics] { return metrics.render(); };
  return source;
}

/// SIGHUP: the file again; the running configuration stays when it is refused.
void reload(const DaemonOptions& options, Service& service, DaemonInfo& info) {
  notify("RELOADING=1");
  try {
    Config next = load_config(options.config_path);
    apply_overrides(options, next);
    for (const std::string& w : config_warnings(next)) spdlog::warn("{}", w);
    service.reload(next);
    info.update(next, options.config_path);
    spdlog::info("configuration reloaded from {}", options.config_path);
  } catch (const std::exception& e) {
    spdlog::error("reload refused, keeping the running configuration: {}", e.what());
    notify("STATUS=reload refused: " + std::string(e.what()));
  }
  notify("READY=1");
}

/// Until SIGTERM or SIGINT: reloads on SIGHUP, the watchdog while every thread lives, STATUS=.
void signal_loop(const DaemonOptions& options, const sigset_t& signals, Service& service, DaemonInfo& info) {
  std::uint64_t watchdog_us = 0;
  const bool watchdog = sd_watchdog_enabled(0, &watchdog_us) > 0 && watchdog_us > 0;
  const auto watchdog_period = std::chrono::microseconds(watchdog_us / 2);
  auto last_watchdog = std::chrono::steady_clock::now();
  auto last_status = last_watchdog;
  for (;;) {
    const timespec wait{0, 200'000'000};  // 200 ms
    const int sig = sigtimedwait(&signals, nullptr, &wait);
    if (sig == SIGTERM || sig == SIGINT) {
      spdlog::info("palletd stopping ({})", sig == SIGTERM ? "SIGTERM" : "SIGINT");
      return;
    }
    if (sig == SIGHUP) reload(options, service, info);
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
}

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
  for (const std::string& w : config_warnings(config)) spdlog::warn("{}", w);
  Service service(config);
  DaemonInfo info;
  info.update(config, options.config_path);
  Metrics metrics(metrics_source(service, info), BuildInfo{PALLETD_VERSION, PALLETD_GIT_COMMIT});
  service.set_result_listener([&metrics](const ResultSnapshot& result) { metrics.observe(result); });
  if (Status started = service.start(); !started) {
    spdlog::critical("palletd cannot start: {}", started.error());
    notify("STATUS=cannot start: " + started.error());
    return 1;
  }
  // The status page and the metrics server, bound before READY=1 like the Modbus port.
  const StatusSource source = status_source(service, info, metrics, config.modbus.handshake.word_order);
  std::unique_ptr<WebServer> web, metrics_server;
  const bool serving = (!config.web.enabled || (web = start_http(config.web.server, source, "web"))) &&
                       (!config.metrics.enabled ||
                        (metrics_server = start_http(config.metrics.server, source, "metrics")));
  if (serving) {
    notify("READY=1\nSTATUS=" + service.status_line());
    spdlog::info("palletd ready: {}", service.status_line());
    signal_loop(options, signals, service, info);
    notify("STOPPING=1");
  }
  if (metrics_server) metrics_server->stop();
  if (web) web->stop();
  service.stop();
  if (serving) spdlog::info("palletd stopped");
  return serving ? 0 : 1;
}

}  // namespace palletd
