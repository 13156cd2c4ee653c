#include "replay/replay_camera.hpp"

#include <algorithm>
#include <filesystem>
#include <thread>
#include <utility>

#include "palletd/frames/frame_io.hpp"
#include "replay/cloud_frame.hpp"

namespace palletd {

namespace fs = std::filesystem;

ReplayCamera::ReplayCamera(ReplayOptions options) : options_(std::move(options)) {
  CameraIdentity id;
  id.driver = "replay";
  id.model = "replay";
  id.serial = fs::path(options_.directory).filename().string();
  if (id.serial.empty()) id.serial = fs::path(options_.directory).parent_path().filename().string();
  id.address = options_.directory;
  set_identity(std::move(id));
}

bool ReplayCamera::directory_present() const {
  std::error_code ec;
  return fs::is_directory(options_.directory, ec);
}

Status ReplayCamera::list_stems() {
  if (!directory_present()) {
    return Error{"replay folder " + options_.directory + " does not exist"};
  }
  Expected<std::vector<std::string>> stems = list_frame_stems(options_.directory);
  if (!stems) return Error{"replay folder " + options_.directory + ": " + stems.error()};
  // Organized clouds (*.pcd, *.ply) play in name order among the frames.
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(options_.directory, ec)) {
    if (entry.is_regular_file(ec) && is_cloud_path(entry.path().string())) stems->push_back(entry.path().string());
  }
  if (stems->empty()) {
    return Error{"replay folder " + options_.directory + " holds no frames (no *.depth.png, *.pcd or *.ply)"};
  }
  std::sort(stems->begin(), stems->end());
  stems_ = std::move(stems.value());
  return {};
}

Status ReplayCamera::do_open() {
  if (options_.directory.empty()) return Error{"replay: no folder configured (camera.replay.directory)"};
  Status status = list_stems();
  if (!status) return status;
  next_index_ = 0;
  return {};
}

Status ReplayCamera::do_start() {
  {
    std::lock_guard<std::mutex> lock(trigger_mutex_);
    pending_triggers_ = 0;
  }
  next_due_ = std::chrono::steady_clock::now();
  return {};
}

Status ReplayCamera::do_stop() { return {}; }

void ReplayCamera::do_close() {
  stems_.clear();
  next_index_ = 0;
}

Status ReplayCamera::do_software_trigger() {
  {
    std::lock_guard<std::mutex> lock(trigger_mutex_);
    ++pending_triggers_;
  }
  trigger_cv_.notify_one();
  return {};
}

Expected<Frame> ReplayCamera::do_grab(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  if (trigger_mode()) {
    std::unique_lock<std::mutex> lock(trigger_mutex_);
    if (!trigger_cv_.wait_until(lock, deadline, [this] { return pending_triggers_ > 0; })) {
      count_timeout();
      return Error{"replay " + options_.directory + ": no software trigger within " +
                   std::to_string(timeout.count()) + " ms"};
    }
    --pending_triggers_;
  } else {
    if (next_due_ > deadline) {
      std::this_thread::sleep_until(deadline);
      count_timeout();
      return Error{"replay " + options_.directory + ": no frame within " +
                   std::to_string(timeout.count()) + " ms at " + std::to_string(options_.rate_hz) +
                   " Hz"};
    }
    std::this_thread::sleep_until(next_due_);
    const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(1.0 / options_.rate_hz));
    next_due_ += period;
    const auto now = std::chrono::steady_clock::now();
    if (next_due_ < now) next_due_ = now;  // a late caller: resynchronise, never burst
  }

  if (!directory_present()) {
    mark_faulted();
    return Error{"replay folder " + options_.directory + " is gone"};
  }
  if (next_index_ >= stems_.size()) {
    if (!options_.loop) {
      return Error{"replay " + options_.directory + ": end of recording after " +
                   std::to_string(stems_.size()) + " frames (loop is off)"};
    }
    Status listed = list_stems();  // pick up frames added or removed meanwhile
    if (!listed) {
      mark_faulted();
      return Error{listed.error()};
    }
    next_index_ = 0;
  }

  const std::string& stem = stems_[next_index_++];
  Expected<Frame> frame = is_cloud_path(stem) ? read_cloud_frame(stem) : read_frame(stem);
  if (!frame) {
    incomplete_++;
    return Error{"replay frame " + stem + ": " + frame.error()};
  }
  if (options_.intrinsics_override) {
    const Intrinsics& k = *options_.intrinsics_override;
    if (k.width != frame->intrinsics.width || k.height != frame->intrinsics.height) {
      incomplete_++;
      return Error{"replay frame " + stem + ": size " + std::to_string(frame->intrinsics.width) +
                   "x" + std::to_string(frame->intrinsics.height) +
                   " differs from the configured intrinsics " + std::to_string(k.width) + "x" +
                   std::to_string(k.height)};
    }
    frame->intrinsics = k;
  }
  if (frame->camera_id.empty()) frame->camera_id = identity().id();
  frame->sequence = sequence_++;
  frame->timestamp_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
  return frame;
}

}  // namespace palletd
