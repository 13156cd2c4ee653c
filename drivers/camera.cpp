// The camera state machine (shared by every driver), Backoff and CameraSupervisor.
#include "palletd/drivers/camera.hpp"

#include <algorithm>
#include <thread>
#include <utility>

namespace palletd {

const char* to_string(CameraState state) {
  switch (state) {
    case CameraState::kClosed: return "closed";
    case CameraState::kOpen: return "open";
    case CameraState::kStreaming: return "streaming";
    case CameraState::kFaulted: return "faulted";
  }
  return "unknown";
}

std::string CameraIdentity::id() const {
  if (model.empty() && serial.empty()) return driver;
  if (serial.empty()) return model;
  if (model.empty()) return serial;
  return model + "-" + serial;
}

Status Camera::fail(std::string message) {
  std::lock_guard<std::mutex> lock(text_mutex_);
  last_error_ = message;
  return Error{std::move(message)};
}

Status Camera::open() {
  const CameraState s = state();
  if (s != CameraState::kClosed && s != CameraState::kFaulted) {
    return fail(std::string("camera open: refused in state ") + to_string(s) + " (close it first)");
  }
  if (s == CameraState::kFaulted) {
    do_close();
    state_ = CameraState::kClosed;
  }
  Status status = do_open();
  if (!status) {
    do_close();
    return fail("camera open: " + status.error());
  }
  state_ = CameraState::kOpen;
  if (faulted_since_open_) {
    ++reconnects_;
    faulted_since_open_ = false;
  }
  return {};
}

Status Camera::start() {
  const CameraState s = state();
  if (s == CameraState::kStreaming) return {};
  if (s != CameraState::kOpen) {
    return fail(std::string("camera start: refused in state ") + to_string(s) + " (open it first)");
  }
  Status status = do_start();
  if (!status) return fail("camera start: " + status.error());
  state_ = CameraState::kStreaming;
  return {};
}

Status Camera::stop() {
  const CameraState s = state();
  if (s == CameraState::kOpen) return {};
  if (s != CameraState::kStreaming) {
    return fail(std::string("camera stop: refused in state ") + to_string(s));
  }
  Status status = do_stop();
  state_ = CameraState::kOpen;
  if (!status) return fail("camera stop: " + status.error());
  return {};
}

void Camera::close() {
  if (state() == CameraState::kClosed) return;
  do_close();
  state_ = CameraState::kClosed;
}

Expected<Frame> Camera::grab(std::chrono::milliseconds timeout) {
  const CameraState s = state();
  if (s != CameraState::kStreaming) {
    return Error{fail(std::string("camera grab: refused in state ") + to_string(s)).error()};
  }
  fault_pending_ = false;
  Expected<Frame> frame = do_grab(timeout);
  if (frame) {
    ++frames_;
    return frame;
  }
  if (fault_pending_) {
    fault_pending_ = false;
    faulted_since_open_ = true;
    ++faults_;
    state_ = CameraState::kFaulted;
  }
  return Error{fail(frame.error()).error()};
}

Status Camera::software_trigger() {
  const CameraState s = state();
  if (s != CameraState::kStreaming) {
    return fail(std::string("camera trigger: refused in state ") + to_string(s));
  }
  if (!trigger_mode()) return fail("camera trigger: the camera is free-running (not in trigger mode)");
  fault_pending_ = false;
  Status status;
  {
    ControlCall call(*this);
    status = do_software_trigger();
  }
  if (!status) {
    if (fault_pending_) {  // the driver found the camera gone while triggering
      fault_pending_ = false;
      faulted_since_open_ = true;
      ++faults_;
      state_ = CameraState::kFaulted;
    }
    return fail("camera trigger: " + status.error());
  }
  return {};
}

Status Camera::do_software_trigger() { return Error{"this camera has no software trigger"}; }

void Camera::check_alive() {
  if (state() != CameraState::kStreaming || do_alive()) return;
  faulted_since_open_ = true;
  ++faults_;
  state_ = CameraState::kFaulted;
  (void)fail("camera " + identity().id() + " lost (the driver lost its control channel)");
}

CameraCounters Camera::counters() const {
  CameraCounters c;
  c.frames = frames_.load();
  c.drops = drops_.load();
  c.incomplete = incomplete_.load();
  c.resent = resent_.load();
  c.timeouts = timeouts_.load();
  c.reconnects = reconnects_.load();
  c.faults = faults_.load();
  return c;
}

CameraIdentity Camera::identity() const {
  std::lock_guard<std::mutex> lock(text_mutex_);
  return identity_;
}

std::string Camera::last_error() const {
  std::lock_guard<std::mutex> lock(text_mutex_);
  return last_error_;
}

void Camera::set_identity(CameraIdentity identity) {
  std::lock_guard<std::mutex> lock(text_mutex_);
  identity_ = std::move(identity);
}

void Camera::count_timeout() { ++timeouts_; }

namespace {
std::int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

Camera::ControlCall::ControlCall(Camera& camera) : camera_(camera) {
  std::int64_t idle = 0;
  // steady_now_ns() is never 0 on a running system; 0 marks "no call".
  outermost_ = camera_.control_call_since_ns_.compare_exchange_strong(idle, steady_now_ns());
}

Camera::ControlCall::~ControlCall() {
  if (outermost_) camera_.control_call_since_ns_.store(0);
}

std::chrono::milliseconds Camera::control_call_age() const {
  const std::int64_t since = control_call_since_ns_.load();
  if (since == 0) return std::chrono::milliseconds(0);
  return std::chrono::duration_cast<std::chrono::milliseconds>(
      std::chrono::nanoseconds(std::max<std::int64_t>(0, steady_now_ns() - since)));
}

// ---------------------------------------------------------------------------------------------

Backoff::Backoff(double min_s, double max_s)
    : min_s_(std::max(min_s, 0.0)), max_s_(std::max(max_s, std::max(min_s, 0.0))), next_s_(min_s_) {}

double Backoff::next_delay_s() {
  const double delay = next_s_;
  next_s_ = std::min(max_s_, std::max(next_s_ * 2.0, min_s_));
  return delay;
}

CameraSupervisor::CameraSupervisor(std::unique_ptr<Camera> camera, double reconnect_min_s,
                                   double reconnect_max_s, std::chrono::milliseconds control_timeout)
    : camera_(std::move(camera)), backoff_(reconnect_min_s, reconnect_max_s),
      control_timeout_(control_timeout), next_attempt_(std::chrono::steady_clock::now()) {}

CameraSupervisor::~CameraSupervisor() { shutdown(); }

Status CameraSupervisor::bring_up() {
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard<std::mutex> lock(retry_mutex_);
    if (now < next_attempt_) return Error{"not yet due"};
  }
  if (camera_->state() == CameraState::kFaulted) camera_->close();
  Status status;
  if (camera_->state() == CameraState::kClosed) status = camera_->open();
  if (status) status = camera_->start();
  if (status) {
    backoff_.reset();
    return {};
  }
  camera_->close();
  const double delay_s = backoff_.next_delay_s();
  std::lock_guard<std::mutex> lock(retry_mutex_);
  next_attempt_ = std::chrono::steady_clock::now() +
                  std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                      std::chrono::duration<double>(delay_s));
  return status;
}

Expected<Frame> CameraSupervisor::grab(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  if (camera_->state() != CameraState::kStreaming) {
    Status up = bring_up();
    if (!up) {
      // Not streaming: wait out the timeout (or until the next attempt is due) so a caller
      // that loops on grab() does not spin.
      std::chrono::steady_clock::time_point wake;
      {
        std::lock_guard<std::mutex> lock(retry_mutex_);
        wake = std::min(deadline, next_attempt_);
      }
      std::this_thread::sleep_until(wake);
      return Error{"camera " + camera_->identity().id() + " not streaming (" +
                   to_string(camera_->state()) + "): " + camera_->last_error()};
    }
  }
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
      deadline - std::chrono::steady_clock::now());
  Expected<Frame> frame = camera_->grab(std::max(left, std::chrono::milliseconds(1)));
  if (!frame && camera_->state() == CameraState::kFaulted) {
    // Reconnect at once the first time; later failures back off.
    std::lock_guard<std::mutex> lock(retry_mutex_);
    next_attempt_ = std::chrono::steady_clock::now();
  }
  return frame;
}

bool CameraSupervisor::ensure_streaming() {
  if (camera_->state() == CameraState::kStreaming) camera_->check_alive();
  if (camera_->state() == CameraState::kStreaming) return true;
  return bring_up().ok();
}

Status CameraSupervisor::software_trigger() {
  if (camera_->state() != CameraState::kStreaming) {
    return Error{std::string("camera trigger: camera is ") + to_string(camera_->state())};
  }
  return camera_->software_trigger();
}

void CameraSupervisor::shutdown() {
  if (camera_->state() == CameraState::kStreaming) (void)camera_->stop();
  camera_->close();
}

double CameraSupervisor::seconds_to_retry() const {
  if (camera_->state() == CameraState::kStreaming) return 0.0;
  std::lock_guard<std::mutex> lock(retry_mutex_);
  const auto left = next_attempt_ - std::chrono::steady_clock::now();
  return std::max(0.0, std::chrono::duration<double>(left).count());
}

}  // namespace palletd
