#include "acquisition.hpp"

#include <string>

#include <spdlog/spdlog.h>

namespace palletd {

using namespace std::chrono_literals;

Acquisition::Acquisition(std::unique_ptr<CameraSupervisor> camera, StatusCallback on_status)
    : camera_(std::move(camera)), on_status_(std::move(on_status)) {
  mark_alive();
}

Acquisition::~Acquisition() { stop(); }

void Acquisition::start() {
  if (running_.exchange(true)) return;
  mark_alive();
  thread_ = std::thread([this] { run(); });
}

void Acquisition::stop() {
  if (!running_.exchange(false)) {
    if (thread_.joinable()) thread_.join();
    return;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  camera_->shutdown();
  // Answer a caller still waiting.
  std::lock_guard<std::mutex> lock(mutex_);
  if (pending_ != nullptr && !pending_->answer)
    pending_->answer = Expected<Frame>(Error{"acquisition stopped"});
  cv_.notify_all();
}

Expected<Frame> Acquisition::frame_after(Clock::time_point trigger_time, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!running_) return Error{"acquisition is not running"};
  Request request{next_id_++, trigger_time, Clock::now() + timeout, std::nullopt};
  pending_ = &request;
  cv_.notify_all();
  // The acquisition thread answers by the deadline (plus its own grab slice); wait a little past it.
  cv_.wait_until(lock, request.deadline + 500ms, [&] { return request.answer.has_value() || !running_; });
  pending_ = nullptr;
  if (request.answer) return std::move(*request.answer);
  return Error{"no frame within " + std::to_string(timeout.count()) + " ms (acquisition did not answer)"};
}

Expected<Frame> Acquisition::acquire(const Request& request) {
  auto left = [&] {
    return std::max(1ms, std::chrono::duration_cast<std::chrono::milliseconds>(request.deadline - Clock::now()));
  };
  camera_->ensure_streaming();
  if (camera_->trigger_mode()) {
    Status triggered = camera_->software_trigger();
    if (!triggered) {
      // The camera found gone by this very trigger is not asked again now (every call on a
      // vanished GigE camera blocks for seconds); the idle loop reconnects it with backoff.
      if (camera_->state() == CameraState::kFaulted) return Error{triggered.error()};
      // Not streaming yet: the camera may just have come back. One more try after bringing it up.
      camera_->ensure_streaming();
      triggered = camera_->software_trigger();
      if (!triggered) return Error{triggered.error()};
    }
    const std::uint64_t timeouts_before = camera_->counters().timeouts;
    Expected<Frame> frame = camera_->grab(left());
    const bool timed_out = !frame && camera_->counters().timeouts > timeouts_before;
    if (!timed_out) {
      failed_in_row_ = 0;  // a frame, or a bad one (counted by the driver): the camera delivers
    } else if (camera_->camera_ok() && ++failed_in_row_ >= kRestartAfterFailures) {
      // Streaming by its own account, yet no frame trigger after trigger (acquisition stopped
      // on the camera side): start it afresh.
      spdlog::warn("camera {}: no frame for {} triggers in a row ({}); restarting it",
                   camera_->identity().id(), failed_in_row_, frame.error());
      failed_in_row_ = 0;
      restarts_.fetch_add(1);
      camera_->shutdown();
      camera_->ensure_streaming();
    }
    return frame;
  }
  // The trigger on the drivers' clock (Frame::timestamp_ns: arrival, system clock).
  const std::int64_t trigger_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(
          (std::chrono::system_clock::now() - (Clock::now() - request.trigger_time)).time_since_epoch())
          .count();
  int completed_after_trigger = 0;
  while (Clock::now() < request.deadline && running_) {
    Expected<Frame> frame = camera_->grab(left());
    mark_alive();
    if (!frame) return frame;
    // Arrived before the trigger (the stream's queue fills between triggers; a stalled camera
    // leaves what it sent last): never the trigger's frame, however many wait.
    if (frame->timestamp_ns != 0 && frame->timestamp_ns < trigger_ns) {
      stale_dropped_.fetch_add(1);
      continue;
    }
    // The first one completed after the trigger: its exposure may predate it.
    if (++completed_after_trigger < 2) {
      stale_dropped_.fetch_add(1);
      continue;
    }
    return frame;
  }
  return Error{"no frame captured after the trigger within the frame timeout"};
}

void Acquisition::run() {
  auto last_status = Clock::now() - 1s;
  bool took_frame = false;  // the last idle grab brought a frame: the next one waits in grab()
  while (running_) {
    mark_alive();
    bool have_request = false;
    Request copy;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait_for(lock, took_frame ? 0ms : 100ms,
                   [&] { return !running_ || (pending_ != nullptr && !pending_->answer); });
      if (!running_) break;
      if (pending_ != nullptr && !pending_->answer) {
        have_request = true;
        copy = Request{pending_->id, pending_->trigger_time, pending_->deadline, std::nullopt};
      }
    }
    took_frame = false;
    if (have_request) {
      // Work on a copy: the caller may give up (past its deadline) and its request is gone.
      Expected<Frame> frame = acquire(copy);
      std::lock_guard<std::mutex> lock(mutex_);
      if (pending_ != nullptr && pending_->id == copy.id) {
        pending_->answer = std::move(frame);
        cv_.notify_all();
      }
    } else if (!camera_->trigger_mode()) {
      // Free-running: every frame taken as it comes (grab() waits for it), so the stream's
      // buffers stay free (none dropped for want of one) and a request finds fresh frames.
      took_frame = camera_->grab(100ms).ok();
    } else {
      camera_->ensure_streaming();
    }
    if (Clock::now() - last_status >= 100ms) {
      last_status = Clock::now();
      if (on_status_) on_status_(*camera_);
    }
  }
}

}  // namespace palletd
