// palletd web: the status page a cell integrator and maintenance staff open in a browser.
//
// An HTTP server (cpp-httplib) on its own threads, loopback by default, read-only except for the
// guarded POST /api/snapshot. It serves:
//   GET  /                        self-contained HTML page (inline CSS/JS, no CDN); refreshes itself
//   GET  /api/status              JSON: status in words, counters, camera, recipe, Modbus registers
//   GET  /api/result              JSON: the detection line (shared/spec/detections.md) + "trigger"
//   GET  /api/overlay.png         the last frame with layer outline and numbered boxes
//   GET  /api/frame/depth.png     the last frame in the frame format (shared/spec/frames.md) ...
//   GET  /api/frame/intensity.png ... (404 when the frame has no intensity)
//   GET  /api/frame/meta.json     ... STEM.json, so a support engineer can replay the frame
//   GET  /api/frame/detection.json  the detection line of that frame (as the recorder stores it)
//   POST /api/snapshot            asks the service to store the next frame (403 unless allowed)
//   GET  /metrics                 the Prometheus text format (StatusSource::metrics; 404 without)
// With WebOptions::status_page false it serves /metrics alone (the `metrics:` section's server).
//
// The server never blocks the service: it pulls snapshots through StatusSource (all callbacks
// must be thread-safe) and renders overlays and frame files lazily, once per snapshot.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "palletd/core/expected.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/status/snapshot.hpp"

namespace palletd {

struct WebOptions {
  std::string bind_address = "127.0.0.1";  ///< numeric address or host name; loopback by default
  int port = 8080;                         ///< 0 = any free port (see WebServer::port())
  bool allow_snapshot_post = false;        ///< POST /api/snapshot refused (403) unless true
  int refresh_ms = 1000;                   ///< how often the page polls [ms]
  std::size_t stats_window = 1000;         ///< results kept for the p50/p99 figures
  std::chrono::milliseconds sample_period{100};  ///< how often new snapshots are looked for
  int threads = 2;                         ///< HTTP worker threads
  /// Host names the page may be opened by, besides numeric addresses and "localhost". Requests
  /// naming another host are refused (403): a foreign page cannot read the status through DNS
  /// rebinding.
  std::vector<std::string> allowed_hosts;
  /// false: only GET /metrics (and 404 for the rest): the metrics server of the `metrics:` section.
  bool status_page = true;
  /// Optional log sink (start/stop, refused requests), called from server threads.
  std::function<void(const std::string&)> log;
};

/// The read-only status page served by the daemon (docs/commissioning.md): whether it runs, and
/// the server's own options.
struct WebConfig {
  bool enabled = false;
  WebOptions server;
};

/// The `metrics:` section: GET /metrics on a server of its own, for when the status page is off
/// or must not be reachable from where Prometheus scrapes. Same host rules as the page.
struct MetricsConfig {
  bool enabled = false;
  WebOptions server = [] {
    WebOptions o;
    o.port = 9482;
    o.status_page = false;
    return o;
  }();
};

/// A recipe as the page shows it: number, name and its box formats (index = DetectedBox::format).
struct RecipeInfo {
  int number = 0;
  std::string name;
  std::vector<BoxFormat> formats;
};


/// Where the server gets its data. Every callback may be called from any server thread at any
/// time and must be thread-safe; latest, health and registers are required.
struct StatusSource {
  std::function<std::shared_ptr<const ResultSnapshot>()> latest;  ///< null before the first result
  std::function<ServiceHealth()> health;
  std::function<modbus::RegisterImage()> registers;  ///< the image as the PLC reads it
  std::function<std::vector<RecipeInfo>()> recipes;  ///< optional; names and formats for the page
  /// Optional: store the next frame with its result and overlay (SaveSnapshot). Empty = the
  /// service cannot; POST /api/snapshot then answers 501.
  std::function<Status()> request_snapshot;
  modbus::WordOrder word_order = modbus::WordOrder::kHighWordFirst;  ///< of 32-bit registers
  /// Optional: the Prometheus text for GET /metrics (Metrics::render()). Empty = 404.
  std::function<std::string()> metrics;
};

class WebServer {
 public:
  WebServer(WebOptions options, StatusSource source);
  ~WebServer();  ///< stop()s
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;
  WebServer(WebServer&&) = delete;
  WebServer& operator=(WebServer&&) = delete;

  /// Binds (so the port is taken when this returns ok), then starts the HTTP and sampler threads.
  /// Fails on a missing required callback, a bad address or a port in use. Call it once.
  Status start();
  /// Stops serving and joins every thread. Idempotent.
  void stop();
  /// The bound port (meaningful after a successful start()).
  [[nodiscard]] int port() const;

  /// Feeds a snapshot to the counters (the sampler thread does this by itself; a caller that sees
  /// every result can call it too: each trigger_seq is counted once).
  void observe(const std::shared_ptr<const ResultSnapshot>& snapshot);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palletd
