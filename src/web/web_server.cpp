#include "palletd/web/web.hpp"

#include <arpa/inet.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <sstream>
#include <thread>

#include "palletd/results/detection_json.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/results/overlay.hpp"
#include "rolling_stats.hpp"
#include "status_json.hpp"

// After Eigen: httplib.h pulls in <resolv.h>, whose _res macro breaks Eigen's headers.
#include <httplib.h>

namespace palletd {

extern const char* const kStatusPageHtml;  // status_page.cpp (generated from status_page.html)

/// A frame's files as the status page serves them (a member of WebServer::Impl's cache, so not
/// in the unnamed namespace).
struct FrameFiles {
  std::string depth_png, intensity_png, meta_json;
  std::string error;  ///< non-empty when they could not be produced
};

namespace {

namespace fs = std::filesystem;

/// The Prometheus text exposition format's content type.
constexpr const char* kMetricsContentType = "text/plain; version=0.0.4; charset=utf-8";
using web::Json;

std::string read_file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// The frame in the frame format, written by write_frame into a private temporary folder and read
/// back, so the downloads are byte for byte what the recorder would store.
FrameFiles encode_frame_files(const Frame& frame) {
  FrameFiles files;
  std::error_code ec;
  std::string pattern = (fs::temp_directory_path(ec) / "palletd-web-XXXXXX").string();
  if (ec) pattern = "/tmp/palletd-web-XXXXXX";
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  if (mkdtemp(buf.data()) == nullptr) {
    files.error = "cannot create a temporary folder for the frame files";
    return files;
  }
  const fs::path dir(buf.data());
  const std::string stem = (dir / "frame").string();
  if (Status s = write_frame(stem, frame); !s) {
    files.error = s.error();
  } else {
    files.depth_png = read_file_bytes(stem + ".depth.png");
    files.meta_json = read_file_bytes(stem + ".json");
    if (frame.has_intensity()) files.intensity_png = read_file_bytes(stem + ".intensity.png");
  }
  fs::remove_all(dir, ec);
  return files;
}

/// The Host header names this server by a numeric address, "localhost" or an allowed name.
bool host_allowed(const std::string& host_header, const std::vector<std::string>& allowed) {
  std::string host = host_header;
  if (!host.empty() && host.front() == '[') {  // [IPv6]:port
    const auto end = host.find(']');
    if (end == std::string::npos) return false;
    host = host.substr(1, end - 1);
    in6_addr a6{};
    return inet_pton(AF_INET6, host.c_str(), &a6) == 1;
  }
  const auto colon = host.rfind(':');
  if (colon != std::string::npos) host.resize(colon);
  in_addr a4{};
  if (inet_pton(AF_INET, host.c_str(), &a4) == 1) return true;
  for (char& c : host) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (host == "localhost") return true;
  return std::find(allowed.begin(), allowed.end(), host) != allowed.end();
}

void send_json(httplib::Response& res, const Json& j, int status = 200) {
  res.status = status;
  res.set_content(j.dump(), "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& message) {
  send_json(res, Json{{"error", message}}, status);
}

void attachment(httplib::Response& res, const std::string& filename) {
  res.set_header("Content-Disposition", "attachment; filename=\"" + filename + "\"");
}

}  // namespace

class WebServer::Impl {
 public:
  Impl(WebOptions options, StatusSource source)
      : options_(std::move(options)), source_(std::move(source)), processing_(options_.stats_window),
        latency_(options_.stats_window) {
    page_ = kStatusPageHtml;
    const std::string key = "__REFRESH_MS__";
    for (auto pos = page_.find(key); pos != std::string::npos; pos = page_.find(key))
      page_.replace(pos, key.size(), std::to_string(options_.refresh_ms));
  }

  ~Impl() { stop(); }

  Status start() {
    if (!source_.latest || !source_.health || !source_.registers)
      return Error{"web server: the status source lacks latest, health or registers"};
    if (started_) return Error{"web server: start() called twice"};
    started_ = true;
    const int threads = std::max(1, options_.threads);
    server_.new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<std::size_t>(threads)); };
    server_.set_default_headers({{"Cache-Control", "no-store"}, {"X-Content-Type-Options", "nosniff"}});
    server_.set_keep_alive_max_count(100);
    server_.set_payload_max_length(4096);  // the only body we accept is an empty POST
    // httplib's default sets SO_REUSEPORT, which lets a second process bind the same port
    // silently: SO_REUSEADDR only (a restart still binds while old connections sit in TIME_WAIT).
    server_.set_socket_options([](socket_t sock) {
      int yes = 1;
      setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    });
    routes();
    if (options_.port == 0) {
      port_ = server_.bind_to_any_port(options_.bind_address);
      if (port_ <= 0) return Error{"web server: cannot bind " + options_.bind_address};
    } else {
      if (!server_.bind_to_port(options_.bind_address, options_.port))
        return Error{"web server: cannot bind " + options_.bind_address + " port " + std::to_string(options_.port) +
                     " (in use, or not an address of this machine)"};
      port_ = options_.port;
    }
    http_thread_ = std::thread([this] { server_.listen_after_bind(); });
    // httplib's stop() only works once the loop runs: wait for it (bounded).
    for (int i = 0; i < 500 && !server_.is_running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    sampler_thread_ = std::thread([this] { sample_loop(); });
    log(std::string(options_.status_page ? "status page" : "metrics") + " on http://" + options_.bind_address + ":" +
        std::to_string(port_) + (options_.status_page ? "/" : "/metrics"));
    return {};
  }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(stop_mutex_);
      stopping_ = true;
    }
    stop_cv_.notify_all();
    if (sampler_thread_.joinable()) sampler_thread_.join();
    if (http_thread_.joinable()) {
      server_.stop();
      http_thread_.join();
    }
  }

  [[nodiscard]] int port() const { return port_; }

  void observe(const std::shared_ptr<const ResultSnapshot>& snapshot) {
    if (!snapshot) return;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (seen_any_ && snapshot->trigger_seq == last_seq_) return;
    seen_any_ = true;
    last_seq_ = snapshot->trigger_seq;
    const auto total = snapshot->detection.timing_ms.find("total");
    if (snapshot->frame && total != snapshot->detection.timing_ms.end()) processing_.add(total->second);
    if (snapshot->latency_ms > 0.0) latency_.add(snapshot->latency_ms);
  }

 private:
  void log(const std::string& line) const {
    if (options_.log) options_.log(line);
  }

  void sample_loop() {
    std::unique_lock<std::mutex> lock(stop_mutex_);
    while (!stopping_) {
      lock.unlock();
      try {
        observe(source_.latest());
      } catch (const std::exception& e) {
        log(std::string("web server: status source failed: ") + e.what());
      }
      lock.lock();
      stop_cv_.wait_for(lock, options_.sample_period, [this] { return stopping_; });
    }
  }

  web::Figures figures() {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    web::Figures f;
    f.window = processing_.size();
    f.processing_p50_ms = processing_.percentile(50.0);
    f.processing_p99_ms = processing_.percentile(99.0);
    f.latency_p50_ms = latency_.percentile(50.0);
    f.latency_p99_ms = latency_.percentile(99.0);
    return f;
  }

  std::vector<RecipeInfo> recipes() const { return source_.recipes ? source_.recipes() : std::vector<RecipeInfo>{}; }

  /// The cache entry of the latest snapshot (replaced when a newer one is published).
  struct Cached {
    std::shared_ptr<const ResultSnapshot> snapshot;
    bool overlay_done = false;
    std::string overlay_png;
    bool files_done = false;
    FrameFiles files;
  };

  /// Runs `fn(cached)` under the cache lock for the latest snapshot; false when there is none.
  template <typename Fn>
  bool with_latest(Fn&& fn) {
    std::shared_ptr<const ResultSnapshot> latest = source_.latest();
    if (!latest) return false;
    observe(latest);
    std::lock_guard<std::mutex> lock(cache_mutex_);
    if (cache_.snapshot != latest) {
      cache_ = Cached{};
      cache_.snapshot = latest;
    }
    fn(cache_);
    return true;
  }

  void routes() {
    const httplib::Server::HandlerWithResponse check_host = [this](const httplib::Request& req,
                                                                   httplib::Response& res) {
      if (host_allowed(req.get_header_value("Host"), options_.allowed_hosts))
        return httplib::Server::HandlerResponse::Unhandled;
      log("web server: refused a request for host \"" + req.get_header_value("Host") + "\" (web.allowed_hosts)");
      send_error(res, 403, "unknown host name: add it to web.allowed_hosts");
      return httplib::Server::HandlerResponse::Handled;
    };
    server_.set_pre_routing_handler(check_host);
    server_.Get("/metrics", [this](const httplib::Request&, httplib::Response& res) {
      if (!source_.metrics) return send_error(res, 404, "this server has no metrics");
      res.set_content(source_.metrics(), kMetricsContentType);
    });
    if (!options_.status_page) return;
    server_.Get("/", [this](const httplib::Request&, httplib::Response& res) {
      res.set_header("Content-Security-Policy",
                     "default-src 'self'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; img-src 'self'");
      res.set_content(page_, "text/html; charset=utf-8");
    });
    server_.Get("/api/status", [this](const httplib::Request&, httplib::Response& res) {
      std::shared_ptr<const ResultSnapshot> latest = source_.latest();
      observe(latest);
      const ServiceHealth health = source_.health();
      const modbus::RegisterImage image = source_.registers();
      send_json(res, web::status_json(health, image, source_.word_order, latest.get(), recipes(), figures(),
                                      options_.allow_snapshot_post, options_.refresh_ms));
    });
    server_.Get("/api/result", [this](const httplib::Request&, httplib::Response& res) {
      std::shared_ptr<const ResultSnapshot> latest = source_.latest();
      if (!latest) return send_error(res, 404, "no result yet: no trigger has been answered");
      observe(latest);
      send_json(res, web::result_json(*latest, web::snapshot_stem(*latest), recipes()));
    });
    server_.Get("/api/overlay.png", [this](const httplib::Request&, httplib::Response& res) {
      std::string png;
      const bool any = with_latest([&](Cached& c) {
        if (!c.overlay_done && c.snapshot->frame) {
          const std::vector<std::uint8_t> bytes = render_overlay_png(*c.snapshot->frame, c.snapshot->detection,
                                                                     c.snapshot->check ? &*c.snapshot->check : nullptr);
          c.overlay_png.assign(bytes.begin(), bytes.end());
        }
        c.overlay_done = true;
        png = c.overlay_png;
      });
      if (!any) return send_error(res, 404, "no result yet");
      if (png.empty()) return send_error(res, 404, "the last result has no frame to draw");
      res.set_content(png, "image/png");
    });
    server_.Get(R"(/api/frame/(depth\.png|intensity\.png|meta\.json|detection\.json))",
                [this](const httplib::Request& req, httplib::Response& res) { frame_file(req.matches[1], res); });
    server_.Post("/api/snapshot", [this](const httplib::Request& req, httplib::Response& res) { snapshot(req, res); });
    // (the HandlerWithResponse overload: httplib 0.11 declares the plain one without defining it)
    const httplib::Server::HandlerWithResponse on_error = [](const httplib::Request&, httplib::Response& res) {
      if (res.body.empty()) send_error(res, res.status, res.status == 404 ? "not found" : "request refused");
      return httplib::Server::HandlerResponse::Handled;
    };
    server_.set_error_handler(on_error);
  }

  void frame_file(const std::string& which, httplib::Response& res) {
    std::string body, content_type, filename, error;
    bool found = true;
    const bool any = with_latest([&](Cached& c) {
      const ResultSnapshot& s = *c.snapshot;
      const std::string stem = web::snapshot_stem(s);
      if (which == "detection.json") {
        body = detection_to_json_line(s.detection, stem) + "\n";
        content_type = "application/json";
        filename = stem + ".detection.json";
        return;
      }
      if (!s.frame) {
        found = false;
        error = "the last result has no frame";
        return;
      }
      if (!c.files_done) c.files = encode_frame_files(*s.frame);
      c.files_done = true;
      if (!c.files.error.empty()) {
        error = c.files.error;
        return;
      }
      if (which == "depth.png") {
        body = c.files.depth_png, content_type = "image/png", filename = stem + ".depth.png";
      } else if (which == "intensity.png") {
        body = c.files.intensity_png, content_type = "image/png", filename = stem + ".intensity.png";
        if (body.empty()) found = false, error = "the last frame has no intensity image";
      } else {
        body = c.files.meta_json, content_type = "application/json", filename = stem + ".json";
      }
    });
    if (!any) return send_error(res, 404, "no result yet");
    if (!found) return send_error(res, 404, error);
    if (!error.empty()) return send_error(res, 500, error);
    attachment(res, filename);
    res.set_content(body, content_type.c_str());
  }

  void snapshot(const httplib::Request& req, httplib::Response& res) {
    if (!options_.allow_snapshot_post) {
      log("web server: POST /api/snapshot refused (web.allow_snapshot_post is false)");
      return send_error(res, 403, "snapshot requests over HTTP are disabled (web.allow_snapshot_post: false)");
    }
    // A page of another site must not trigger it from the operator's browser.
    if (req.has_header("Origin")) {
      const std::string origin = req.get_header_value("Origin");
      if (origin != "http://" + req.get_header_value("Host")) return send_error(res, 403, "cross-origin request refused");
    }
    if (!source_.request_snapshot) return send_error(res, 501, "this service cannot store snapshots");
    const Status s = source_.request_snapshot();
    if (!s) return send_error(res, 503, s.error());
    send_json(res, Json{{"requested", true}, {"message", "the next frame will be stored with its result"}}, 202);
  }

  WebOptions options_;
  StatusSource source_;
  std::string page_;
  httplib::Server server_;
  std::thread http_thread_, sampler_thread_;
  bool started_ = false;
  int port_ = 0;

  std::mutex stop_mutex_;
  std::condition_variable stop_cv_;
  bool stopping_ = false;

  std::mutex stats_mutex_;
  bool seen_any_ = false;
  std::uint64_t last_seq_ = 0;
  web::RollingWindow processing_, latency_;

  std::mutex cache_mutex_;
  Cached cache_;
};

WebServer::WebServer(WebOptions options, StatusSource source)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(source))) {}
WebServer::~WebServer() = default;
Status WebServer::start() { return impl_->start(); }
void WebServer::stop() { impl_->stop(); }
int WebServer::port() const { return impl_->port(); }
void WebServer::observe(const std::shared_ptr<const ResultSnapshot>& snapshot) { impl_->observe(snapshot); }

}  // namespace palletd
