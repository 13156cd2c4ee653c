// palletctl grab / record: frames from the configured camera into frame files.
//
//   palletctl grab --config FILE [-n N] --out DIR     the commissioning engineer's first check:
//                                                      N frames, one line each, then the counters
//   palletctl record --config FILE [--out DIR] [-n N] [--duration-s S] [--max-bytes B]
//                                                      a ring of recordings, reconnecting on faults
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/config/config.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/frames/recorder.hpp"

namespace palletd {

namespace {

std::atomic<bool> g_interrupted{false};

extern "C" void on_sigint(int /*signal*/) { g_interrupted = true; }

std::string frame_line(const Frame& f) {
  std::size_t valid = 0;
  for (const std::uint16_t d : f.depth) valid += d != 0 ? 1u : 0u;
  const double share = f.depth.empty() ? 0.0 : 100.0 * static_cast<double>(valid) / static_cast<double>(f.depth.size());
  char text[256];
  std::snprintf(text, sizeof text, "%dx%d depth_scale %g m, valid %.1f %%, fx %.1f fy %.1f cx %.1f cy %.1f, seq %llu",
                f.intrinsics.width, f.intrinsics.height, f.depth_scale_m, share, f.intrinsics.fx, f.intrinsics.fy,
                f.intrinsics.cx, f.intrinsics.cy, static_cast<unsigned long long>(f.sequence));
  return text;
}

void print_counters(const CameraCounters& c) {
  std::printf("counters: frames %llu, drops %llu, incomplete %llu, resent %llu, timeouts %llu, faults %llu, "
              "reconnects %llu\n",
              static_cast<unsigned long long>(c.frames), static_cast<unsigned long long>(c.drops),
              static_cast<unsigned long long>(c.incomplete), static_cast<unsigned long long>(c.resent),
              static_cast<unsigned long long>(c.timeouts), static_cast<unsigned long long>(c.faults),
              static_cast<unsigned long long>(c.reconnects));
}

std::chrono::milliseconds frame_timeout(const Config& config) {
  return std::chrono::milliseconds(static_cast<long long>(config.camera.frame_timeout_ms));
}

}  // namespace

Expected<Frame> grab_one_frame(const Config& config) {
  std::unique_ptr<Camera> camera = make_camera(config.camera);
  if (Status opened = camera->open(); !opened) return Error{opened.error()};
  if (Status started = camera->start(); !started) {
    camera->close();
    return Error{started.error()};
  }
  if (camera->trigger_mode()) {
    if (Status t = camera->software_trigger(); !t) spdlog::warn("{}", t.error());
  }
  Expected<Frame> frame = camera->grab(frame_timeout(config));
  (void)camera->stop();
  camera->close();
  if (frame && config.T_base_camera) frame->T_base_camera = config.T_base_camera;
  return frame;
}

namespace {

struct GrabArgs {
  std::string config;
  std::string out;
  int count = 1;
};

void run_grab(const GrabArgs& args) {
  const Config config = load_config(args.config);
  std::unique_ptr<Camera> camera = make_camera(config.camera);
  spdlog::info("camera driver {} ({})", config.camera.driver, camera->identity().address);
  Status status = camera->open();
  if (!status) {
    spdlog::error("{}", status.error());
    throw CLI::RuntimeError(1);
  }
  const CameraIdentity id = camera->identity();
  std::printf("camera: %s %s serial %s at %s (%s)\n", id.vendor.c_str(), id.model.c_str(), id.serial.c_str(),
              id.address.c_str(), camera->trigger_mode() ? "software trigger" : "free-running");
  status = camera->start();
  if (!status) {
    spdlog::error("{}", status.error());
    throw CLI::RuntimeError(1);
  }
  std::error_code ec;
  std::filesystem::create_directories(args.out, ec);
  if (ec) {
    spdlog::error("cannot create {}: {}", args.out, ec.message());
    throw CLI::RuntimeError(1);
  }
  int failed = 0;
  for (int i = 0; i < args.count && !g_interrupted; ++i) {
    if (camera->trigger_mode()) {
      Status t = camera->software_trigger();
      if (!t) spdlog::warn("{}", t.error());
    }
    Expected<Frame> frame = camera->grab(frame_timeout(config));
    char name[32];
    std::snprintf(name, sizeof name, "frame-%06d", i);
    const std::string stem = (std::filesystem::path(args.out) / name).string();
    if (!frame) {
      std::printf("%s: error: %s\n", stem.c_str(), frame.error().c_str());
      ++failed;
      if (camera->state() == CameraState::kFaulted) break;
      continue;
    }
    if (config.T_base_camera) frame->T_base_camera = config.T_base_camera;
    Status written = write_frame(stem, frame.value());
    if (!written) {
      std::printf("%s: error: %s\n", stem.c_str(), written.error().c_str());
      ++failed;
      continue;
    }
    std::printf("%s: %s\n", stem.c_str(), frame_line(frame.value()).c_str());
    std::fflush(stdout);
  }
  print_counters(camera->counters());
  (void)camera->stop();
  camera->close();
  if (failed > 0) {
    spdlog::warn("{} of {} grab(s) failed", failed, args.count);
    throw CLI::RuntimeError(1);
  }
}

struct RecordArgs {
  std::string config;
  std::string out;
  long long count = 0;      // 0 = no limit
  double duration_s = 0.0;  // 0 = no limit
  std::uint64_t max_bytes = 0;  // 0 = from the configuration
};

void run_record(const RecordArgs& args) {
  const Config config = load_config(args.config);
  RecorderOptions options;
  options.directory = args.out.empty() ? config.recording.directory : args.out;
  options.max_bytes = args.max_bytes > 0 ? args.max_bytes : config.recording.max_bytes;
  FrameRecorder recorder(options);
  Status scanned = recorder.scan();
  if (!scanned) {
    spdlog::error("{}", scanned.error());
    throw CLI::RuntimeError(1);
  }
  CameraSupervisor camera(make_camera(config.camera), config.camera.reconnect_min_s, config.camera.reconnect_max_s);
  std::signal(SIGINT, on_sigint);
  std::signal(SIGTERM, on_sigint);
  spdlog::info("recording to {} (ring of {} bytes); Ctrl-C stops", options.directory, options.max_bytes);
  const auto until = args.duration_s > 0.0
                         ? std::chrono::steady_clock::now() +
                               std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                   std::chrono::duration<double>(args.duration_s))
                         : std::chrono::steady_clock::time_point::max();
  long long recorded = 0;
  bool was_ok = true;
  while (!g_interrupted && std::chrono::steady_clock::now() < until && (args.count == 0 || recorded < args.count)) {
    if (camera.camera_ok() && camera.trigger_mode()) (void)camera.software_trigger();
    Expected<Frame> frame = camera.grab(frame_timeout(config));
    if (!frame) {
      if (was_ok || camera.camera_ok()) spdlog::warn("{}", frame.error());
      was_ok = camera.camera_ok();
      continue;
    }
    if (!was_ok) spdlog::info("camera {} is back", camera.identity().id());
    was_ok = true;
    if (config.T_base_camera) frame->T_base_camera = config.T_base_camera;
    Expected<std::string> stem = recorder.record(frame.value());
    if (!stem) {
      spdlog::error("{}", stem.error());
      throw CLI::RuntimeError(1);
    }
    ++recorded;
    std::printf("%s: %s\n", stem.value().c_str(), frame_line(frame.value()).c_str());
    std::fflush(stdout);
  }
  camera.shutdown();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  print_counters(camera.counters());
  std::printf("recorded %lld frame(s); %zu recording(s), %llu bytes in %s\n", recorded, recorder.recordings(),
              static_cast<unsigned long long>(recorder.bytes_on_disk()), options.directory.c_str());
}

}  // namespace

void register_grab(CLI::App& app) {
  auto args = std::make_shared<GrabArgs>();
  auto* cmd = app.add_subcommand("grab", "Grab N frames from the configured camera and write them as frame files "
                                         "(the commissioning check)");
  cmd->add_option("--config,-c", args->config, "palletd configuration file (its camera section is used)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--out,-o", args->out, "folder for the frames (created)")->required();
  cmd->add_option("-n,--count", args->count, "number of frames")->check(CLI::PositiveNumber);
  cmd->callback([args] { run_grab(*args); });
}

void register_record(CLI::App& app) {
  auto args = std::make_shared<RecordArgs>();
  auto* cmd = app.add_subcommand("record", "Record frames from the configured camera into a bounded ring on disk, "
                                           "reconnecting after camera faults");
  cmd->add_option("--config,-c", args->config, "palletd configuration file")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out,-o", args->out, "recording folder (default: recording.directory of the configuration)");
  cmd->add_option("-n,--count", args->count, "stop after this many frames (0 = no limit)");
  cmd->add_option("--duration-s", args->duration_s, "stop after this many seconds (0 = no limit) [s]");
  cmd->add_option("--max-bytes", args->max_bytes, "ring size on disk (0 = recording.max_bytes) [bytes]");
  cmd->callback([args] { run_record(*args); });
}

}  // namespace palletd
