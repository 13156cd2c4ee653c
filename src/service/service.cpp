#include "palletd/service/service.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <spdlog/spdlog.h>

#include "palletd/drivers/camera.hpp"
#include "palletd/modbus/server.hpp"

#include "acquisition.hpp"
#include "camera_status.hpp"
#include "drift_keeper.hpp"
#include "health_monitor.hpp"
#include "pick_check_answer.hpp"
#include "recipe_detection.hpp"
#include "result_record.hpp"
#include "result_recording.hpp"
#include "shadow.hpp"
#include "trigger_answer.hpp"

namespace palletd {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

namespace {

/// The search's memory kept between triggers (SearchMemory): room for more than the bundled
/// demo's largest searches (recipe 6 at the 200 ms cap; details in docs/benchmarks.md, "The
/// search's memory kept between searches"); a larger one takes the rest for itself.
constexpr std::size_t kSearchMemoryBytes = std::size_t{48} << 20;
constexpr std::size_t kSearchMemoryNodes = std::size_t{1} << 17;

/// The configured server with what the service adds: the first recipe and a log sink.
modbus::ServerOptions server_options(const Config& config) {
  modbus::ServerOptions o = config.modbus;
  o.handshake.initial_recipe = static_cast<std::uint16_t>(config.pipeline.default_recipe);
  o.log = [](const std::string& line) { spdlog::info("modbus: {}", line); };
  return o;
}

double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

class Service::Impl {
 public:
  explicit Impl(Config config)
      : config_(std::make_shared<const Config>(std::move(config))),
        server_(server_options(*config_)),
        health_monitor_(config_->health) {}

  ~Impl() { stop(); }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  Impl(Impl&&) = delete;
  Impl& operator=(Impl&&) = delete;

  Status start() {
    const Config& cfg = *config_;
    std::unique_ptr<Camera> camera;
    try {
      camera = make_camera(cfg.camera);
    } catch (const std::exception& e) {
      return Error{std::string("camera: ") + e.what()};
    }
    auto supervisor = std::make_unique<CameraSupervisor>(
        std::move(camera), cfg.camera.reconnect_min_s, cfg.camera.reconnect_max_s,
        std::chrono::milliseconds(static_cast<long>(cfg.camera.control_timeout_ms)));
    acquisition_ = std::make_unique<Acquisition>(
        std::move(supervisor), [this](const CameraSupervisor& cam) { publish_status(cam); });
    recording_ = std::make_unique<ResultRecording>(cfg);
    shadow_ = make_shadow(cfg);
    configure_health(cfg);
    Status bound = server_.start();
    if (!bound) return Error{"modbus: " + bound.error()};
    running_ = true;
    mark(pipeline_alive_);
    // Ready in the status block from the first request on (before READY=1 to systemd), not only
    // once the acquisition thread publishes: a PLC reconnecting after a restart sees Ready at once.
    publish_status(acquisition_->camera());
    acquisition_->start();
    pipeline_ = std::thread([this] { pipeline_main(); });
    status_ = std::thread([this] { status_main(); });
    spdlog::info("modbus server listening on {} port {}", cfg.modbus.bind_address, server_.port());
    return {};
  }

  void stop() {
    if (!running_.exchange(false)) return;
    server_.stop();  // wakes wait_event()
    status_cv_.notify_all();
    if (status_.joinable()) status_.join();
    if (pipeline_.joinable()) pipeline_.join();
    if (shadow_) shadow_->stop();
    if (acquisition_) acquisition_->stop();
  }

  void reload(const Config& config) {
    auto next = std::make_shared<Config>(*config_);
    next->formats = config.formats;
    next->recipes = config.recipes;
    next->detection = config.detection;
    next->T_base_camera = config.T_base_camera;
    next->pipeline.detection_timeout_ms = config.pipeline.detection_timeout_ms;
    next->logging = config.logging;
    next->shadow_config = config.shadow_config;
    next->shadow = config.shadow;
    next->health = config.health;
    next->check = config.check;
    reload_health_ = true;  // the pipeline thread reloads the drift reference between triggers
    if (shadow_) shadow_->set_config(config.shadow);
    std::lock_guard<std::mutex> lock(config_mutex_);
    config_ = std::move(next);
  }

  Status request_snapshot() {
    if (!recording_ || !recording_->enabled())
      return Error{"recording is not enabled (recording.enabled in the configuration)"};
    recording_->ask();
    return {};
  }

  std::shared_ptr<const ResultSnapshot> latest() const {
    std::lock_guard<std::mutex> lock(latest_mutex_);
    return latest_;
  }

  ServiceHealth health() const {
    ServiceHealth h;
    const auto now = Clock::now();
    const auto fresh = [&](Clock::time_point t) { return now - t < 5s; };
    // A camera call may block for tens of seconds without the thread being hung: Aravis retries
    // GVCP on a vanished GigE camera (measured 20 s until the fault shows). With 5 s here the
    // watchdog pings stopped for 13 s and systemd (WatchdogSec=10s) would have killed palletd.
    const auto camera_fresh = [&](Clock::time_point t) { return now - t < 60s; };
    h.threads_alive = running_ && fresh(load(pipeline_alive_)) && acquisition_ &&
                      camera_fresh(acquisition_->last_alive()) && fresh(server_.last_alive());
    if (acquisition_) add_camera_health(*acquisition_, h);
    h.cell_health = cell_health();
    h.triggers = triggers_.load();
    h.results = results_.load();
    h.failures = failures_.load();
    h.warm_up_ms = warm_up_ms_.load();
    h.modbus_port = server_.port();
    h.modbus_connections = server_.stats().open_connections;
    if (recording_) {
      h.recordings = recording_->recordings();
      h.recording_failures = recording_->failures();
      h.last_recording_error = recording_->last_error();
    }
    if (shadow_) {
      const ShadowCounters shadow = shadow_->counters();
      h.shadow_enabled = shadow.enabled;
      h.shadow_runs = shadow.runs;
      h.shadow_disagreements = shadow.disagreements;
      h.shadow_skipped = shadow.skipped;
      h.last_shadow_difference = shadow.last_difference;
    }
    return h;
  }

  modbus::RegisterImage registers() const { return server_.registers(); }
  modbus::ServerStats modbus_stats() const { return server_.stats(); }
  std::function<void(const ResultSnapshot&)> result_listener_;  ///< set before start()

 private:
  static void mark(std::atomic<Clock::duration::rep>& slot) {
    slot.store(Clock::now().time_since_epoch().count());
  }
  static Clock::time_point load(const std::atomic<Clock::duration::rep>& slot) {
    return Clock::time_point(Clock::duration(slot.load()));
  }

  std::shared_ptr<const Config> config() const {
    std::lock_guard<std::mutex> lock(config_mutex_);
    return config_;
  }

  // Acquisition thread: camera state into the status block.
  void publish_status(const CameraSupervisor& cam) {
    auto status = std::make_shared<modbus::ServiceStatus>(
        camera_status(cam, acquisition_ ? acquisition_->camera_restarts() : 0, running_.load()));
    // Base frame when calibrated in the config, or when the frames carry camera_to_base (replay of
    // a recording made on a calibrated cell).
    status->poses_in_camera_frame = !config()->T_base_camera.has_value() && !frames_have_base_.load();
    status->health = to_health_record(cell_health());
    server_.publish_status(std::move(status));
  }

  // Status thread: the status block every 100 ms from atomics only. The acquisition thread also
  // publishes, but it may block for seconds inside a camera call (Aravis retrying GVCP on a
  // vanished camera); CameraOK must drop while it does, not when the call returns.
  void status_main() {
    std::unique_lock<std::mutex> lock(status_mutex_);
    while (running_) {
      status_cv_.wait_for(lock, 100ms, [this] { return !running_.load(); });
      if (!running_) break;
      try {
        publish_status(acquisition_->camera());
      } catch (const std::exception& e) {
        spdlog::error("status: {}", e.what());
      }
    }
  }

  void pipeline_main() {
    int warm_up_tries = 0;
    Clock::time_point next_warm_up{};
    while (running_) {
      mark(pipeline_alive_);
      try {
        if (reload_health_.exchange(false)) configure_health(*config());
        std::optional<modbus::HandshakeEvent> event = server_.wait_event(200ms);
        if (!event) {
          if (wants_warm_up(warm_up_tries) && Clock::now() >= next_warm_up) {
            ++warm_up_tries;  // a try counts only once the camera is up
            warm_up_ms_.store(warm_up(*acquisition_, *config(), workspace_));
            next_warm_up = Clock::now() + kWarmUpRetry;
          }
          continue;
        }
        if (event->kind == modbus::EventKind::kSaveSnapshot) {
          if (recording_) recording_->ask();
          continue;
        }
        if (event->kind == modbus::EventKind::kSetDriftReference) {
          set_drift_reference(*event);
          continue;
        }
        handle_trigger(*event);  // a Trigger or a PickCheck
      } catch (const std::exception& e) {
        // Never let one trigger take the worker down: report and go on.
        spdlog::error("pipeline: {}", e.what());
        failures_.fetch_add(1);
      }
    }
  }

  // The warm-up (recipe_detection.hpp) runs while no trigger waits, once the camera is up, before
  // the first trigger; up to five tries a second apart (the first frames of a freshly started
  // stream may come incomplete on a loaded machine). Not on a replay camera: it plays its
  // recording one frame per trigger, and the warm-up would take the first.
  static constexpr std::chrono::seconds kWarmUpRetry{1};
  bool wants_warm_up(int tries) const {
    constexpr int kMaxTries = 5;
    return tries < kMaxTries && warm_up_ms_.load() < 0.0 && triggers_.load() == 0 &&
           config()->camera.driver != "replay" && acquisition_->camera().camera_ok();
  }

  // A Trigger runs a detection; a PickCheck checks the result in the block against a new frame.
  void handle_trigger(const modbus::HandshakeEvent& event) {
    triggers_.fetch_add(1);
    const bool is_check = event.kind == modbus::EventKind::kPickCheck;
    const std::shared_ptr<const Config> cfg = config();
    const std::shared_ptr<const ResultSnapshot> last = is_check ? latest() : nullptr;
    auto snapshot = std::make_shared<ResultSnapshot>();
    snapshot->trigger_seq = event.trigger_seq;
    snapshot->request_id = event.request_id;
    snapshot->recipe = last ? last->recipe : event.recipe;
    modbus::ResultRecord record;
    record.request_id = snapshot->request_id;
    record.recipe = snapshot->recipe;

    const Recipe* recipe = is_check ? nullptr : find_recipe(*cfg, event.recipe);
    const std::vector<int> picked =
        last ? picked_boxes(last->detection, event.picked_box, event.picked_group) : std::vector<int>{};
    std::shared_ptr<const Frame> frame;
    const CheckRefusal refusal = is_check ? refuse_check(last.get(), picked, event) : CheckRefusal{};
    if (refusal) {
      fail(record, *snapshot, modbus::ErrorCode::kPickCheckFailed, static_cast<std::uint16_t>(refusal->first),
           refusal->second);
    } else if (!is_check && recipe == nullptr) {
      fail(record, *snapshot, modbus::ErrorCode::kUnknownRecipe, event.recipe,
           "recipe " + std::to_string(event.recipe) + " is not configured");
    } else {
      Expected<Frame> grabbed = acquisition_->frame_after(
          event.time, std::chrono::milliseconds(static_cast<long>(cfg->camera.frame_timeout_ms)));
      if (!grabbed) {
        const bool camera_ok = acquisition_->camera().camera_ok();
        fail(record, *snapshot,
             camera_ok ? modbus::ErrorCode::kFrameTimeout : modbus::ErrorCode::kCameraDisconnected, 0,
             "frame: " + grabbed.error());
      } else {
        Frame f = std::move(grabbed).value();
        apply_calibration(*cfg, f);
        frames_have_base_ = f.T_base_camera.has_value();
        frame = std::make_shared<const Frame>(std::move(f));
        if (is_check) {
          run_check(*cfg, *last, *frame, picked, record, *snapshot);
        } else {
          run_detection(*cfg, *recipe, *frame, record, *snapshot);
        }
      }
    }
    publish(event, *cfg, snapshot, frame, record);
  }

  void publish(const modbus::HandshakeEvent& event, const Config& cfg,
               const std::shared_ptr<ResultSnapshot>& snapshot, const std::shared_ptr<const Frame>& frame,
               const modbus::ResultRecord& record) {
    const auto done = Clock::now();
    snapshot->latency_ms = ms_between(event.time, done);
    snapshot->time = std::chrono::system_clock::now();
    snapshot->frame = frame;
    // The format flags (base or camera frame) must describe this result when ResultReady rises,
    // and the status page (latest()) shows it by then.
    publish_status(acquisition_->camera());
    {
      std::lock_guard<std::mutex> lock(latest_mutex_);
      latest_ = snapshot;
    }
    server_.publish_result(std::make_shared<const modbus::ResultRecord>(record));
    results_.fetch_add(1);
    const bool detected = frame && !snapshot->check;  // a check reuses the last detection's figures
    if (detected) update_health(*frame, snapshot->detection);  // after the result: never delays it
    if (result_listener_) result_listener_(*snapshot);
    if (shadow_ && detected) shadow_->submit(snapshot);  // a frame came: a detection ran
    spdlog::info("{} {} (request {}, recipe {}): {} box(es), {} in {:.1f} ms",
                 event.kind == modbus::EventKind::kPickCheck ? "pick check" : "trigger", event.trigger_seq,
                 event.request_id, snapshot->recipe, snapshot->detection.boxes.size(),
                 !snapshot->error_text.empty() ? snapshot->error_text
                 : snapshot->check            ? to_string(snapshot->check->verdict)
                                              : to_string(snapshot->detection.status),
                 snapshot->latency_ms);
    recording_->after_result(cfg, *snapshot);
  }

  void run_check(const Config& cfg, const ResultSnapshot& last, const Frame& frame, const std::vector<int>& picked,
                 modbus::ResultRecord& record, ResultSnapshot& snapshot) {
    CheckAnswer answer = answer_pick_check(last, frame, picked, cfg);
    const std::uint16_t request_id = record.request_id;
    record = std::move(answer.record);
    record.request_id = request_id;
    record.recipe = snapshot.recipe;
    snapshot.detection = std::move(answer.detection);
    snapshot.check = std::move(answer.check);
    if (!answer.error_text.empty()) {
      failures_.fetch_add(1);
      snapshot.error = record.error;
      snapshot.error_text = std::move(answer.error_text);
      spdlog::warn("{}", snapshot.error_text);
    }
  }

  void run_detection(const Config& cfg, const Recipe& recipe, const Frame& frame,
                     modbus::ResultRecord& record, ResultSnapshot& snapshot) {
    TriggerAnswer answer = answer_trigger(cfg, recipe, frame, workspace_);
    record = std::move(answer.record);
    record.request_id = snapshot.request_id;
    record.recipe = snapshot.recipe;
    snapshot.detection = std::move(answer.detection);
    if (answer.error_text.empty()) return;
    failures_.fetch_add(1);
    snapshot.error = answer.error;
    snapshot.error_text = std::move(answer.error_text);
    if (answer.error == modbus::ErrorCode::kDetectionTimeout)
      spdlog::warn("trigger failed: {}", snapshot.error_text);
  }

  void fail(modbus::ResultRecord& record, ResultSnapshot& snapshot, modbus::ErrorCode code,
            std::uint16_t detail, std::string text) {
    failures_.fetch_add(1);
    mark_failed(record, code, detail);
    snapshot.error = code;
    snapshot.error_text = std::move(text);
    spdlog::warn("trigger failed: {}", snapshot.error_text);
  }

  // Pipeline thread: the health window, the drift reference and what the status block shows.
  void configure_health(const Config& cfg) {
    health_monitor_.set_limits(cfg.health);
    spdlog::info("{}", drift_.configure(cfg));
    publish_cell_health();
  }

  void update_health(const Frame& frame, const Detection& detection) {
    health_monitor_.add(detection.health);
    health_monitor_.set_drift(drift_.measure(frame));
    publish_cell_health();
    publish_status(acquisition_->camera());
  }

  void publish_cell_health() {
    CellHealth summary = health_monitor_.summary();
    std::lock_guard<std::mutex> lock(cell_health_mutex_);
    cell_health_ = std::move(summary);
  }

  CellHealth cell_health() const {
    std::lock_guard<std::mutex> lock(cell_health_mutex_);
    return cell_health_;
  }

  // Control bit 4: the next frame becomes the drift reference (written to health.drift_reference).
  void set_drift_reference(const modbus::HandshakeEvent& event) {
    const std::shared_ptr<const Config> cfg = config();
    Expected<Frame> grabbed = acquisition_->frame_after(
        event.time, std::chrono::milliseconds(static_cast<long>(cfg->camera.frame_timeout_ms)));
    if (!grabbed) {
      spdlog::error("drift reference not set: no frame: {}", grabbed.error());
      return;
    }
    Frame frame = std::move(grabbed).value();
    apply_calibration(*cfg, frame);
    if (Status set = drift_.set_reference(frame); !set) {
      spdlog::error("drift reference not set: {}", set.error());
      return;
    }
    spdlog::info("drift reference set from frame {} ({})", frame.sequence, cfg->health.drift_reference);
    health_monitor_.set_drift(drift_.measure(frame));
    publish_cell_health();
    publish_status(acquisition_->camera());
  }

  mutable std::mutex config_mutex_;
  std::shared_ptr<const Config> config_;
  modbus::ModbusServer server_;
  std::unique_ptr<Acquisition> acquisition_;
  std::unique_ptr<ResultRecording> recording_;  ///< created by start()
  std::unique_ptr<ShadowRunner> shadow_;     ///< created by start(); its thread ends with stop()
  /// Pipeline thread only: rays, cloud and the search's memory (its budget taken at start-up) reused.
  DetectionWorkspace workspace_{{}, {}, SearchMemory(kSearchMemoryBytes, kSearchMemoryNodes)};
  HealthMonitor health_monitor_;             ///< pipeline thread only
  DriftKeeper drift_;                        ///< pipeline thread only
  mutable std::mutex cell_health_mutex_;
  CellHealth cell_health_;  ///< health_monitor_'s summary; guarded by cell_health_mutex_
  std::atomic<bool> reload_health_{false};
  std::thread pipeline_;
  std::thread status_;
  std::mutex status_mutex_;  ///< for status_cv_ only
  std::condition_variable status_cv_;
  std::atomic<bool> running_{false};
  std::atomic<bool> frames_have_base_{false};  ///< the last frame came with camera_to_base
  std::atomic<Clock::duration::rep> pipeline_alive_{0};
  std::atomic<std::uint64_t> triggers_{0}, results_{0}, failures_{0};
  std::atomic<double> warm_up_ms_{-1.0};  ///< ServiceHealth::warm_up_ms
  mutable std::mutex latest_mutex_;
  std::shared_ptr<const ResultSnapshot> latest_;
};

Service::Service(Config config) : impl_(std::make_unique<Impl>(std::move(config))) {}
Service::~Service() = default;
Status Service::start() { return impl_->start(); }
void Service::stop() { impl_->stop(); }
void Service::reload(const Config& config) { impl_->reload(config); }
Status Service::request_snapshot() { return impl_->request_snapshot(); }
std::shared_ptr<const ResultSnapshot> Service::latest() const { return impl_->latest(); }
ServiceHealth Service::health() const { return impl_->health(); }
modbus::RegisterImage Service::registers() const { return impl_->registers(); }
modbus::ServerStats Service::modbus_stats() const { return impl_->modbus_stats(); }
void Service::set_result_listener(std::function<void(const ResultSnapshot&)> listener) {
  impl_->result_listener_ = std::move(listener);
}

}  // namespace palletd
