#include "palletd/modbus/handshake.hpp"

#include <algorithm>

namespace palletd::modbus {
namespace {

using Duration = Handshake::Clock::duration;

Duration seconds(double s) {
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double>(s));
}

bool rising(std::uint16_t before, std::uint16_t after, std::uint16_t bit) {
  return (after & bit) != 0 && (before & bit) == 0;
}

}  // namespace

Handshake::Handshake(const HandshakeOptions& options, Clock::time_point now)
    : options_(options),
      active_recipe_(options.initial_recipe),
      next_heartbeat_(now + std::chrono::seconds(1)),
      plc_heartbeat_changed_(now) {
  refresh();
}

std::uint16_t Handshake::status_word() const {
  std::uint16_t w = 0;
  const bool error = plc_heartbeat_lost_ || service_.error != ErrorCode::kNone || result_error_;
  if (service_.ready && !plc_heartbeat_lost_) w |= kStReady;
  if (busy_) w |= kStBusy;
  if (trigger_ack_) w |= kStTriggerAck;
  if (result_ready_) w |= kStResultReady;
  if (error) w |= kStError;
  if (missed_trigger_) w |= kStMissedTrigger;
  if (service_.camera_ok) w |= kStCameraOk;
  if ((heartbeat_ & 1u) != 0) w |= kStHeartbeatToggle;
  if (overrun_) w |= kStResultOverrun;
  if ((service_.health.flags & kHealthWindowWarnings) != 0) w |= kStHealthWarning;
  if ((service_.health.flags & kHealthDrift) != 0) w |= kStDriftWarning;
  return w;
}

void Handshake::refresh() {
  StatusRecord s;
  s.status_word = status_word();
  if (plc_heartbeat_lost_) {
    s.error = ErrorCode::kPlcHeartbeatLost;
  } else if (service_.error != ErrorCode::kNone) {
    s.error = service_.error;
    s.error_detail = service_.error_detail;
  } else {
    // A failed result's error and detail; after a result without boxes, why (101 stays 0).
    s.error = result_error_ ? result_error_code_ : ErrorCode::kNone;
    s.error_detail = result_error_detail_;
  }
  s.heartbeat = heartbeat_;
  s.active_recipe = active_recipe_;
  s.acquisition_id = service_.acquisition_id;
  s.result_id = result_id_;
  s.last_request_id = last_request_id_;
  s.poses_in_camera_frame = service_.poses_in_camera_frame;
  s.missed_triggers = missed_count_;
  s.processing_ms = processing_ms_;
  s.latency_ms = latency_ms_;
  s.frames_grabbed = service_.frames_grabbed;
  s.camera_reconnects = service_.camera_reconnects;
  s.camera_faults = service_.camera_faults;
  s.connections = connections_;
  s.health = service_.health;
  encode_status(s, options_.word_order, image_);
  ++version_;
}

std::vector<HandshakeEvent> Handshake::on_control_written(const std::uint16_t* control,
                                                          Clock::time_point now) {
  std::vector<HandshakeEvent> events;
  std::copy(control, control + kControlCount, image_.begin() + kControlStart);
  const std::uint16_t before = prev_control_word_;
  const std::uint16_t after = control[kRegControlWord];
  prev_control_word_ = after;

  const std::uint16_t heartbeat = control[kRegPlcHeartbeat];
  if (heartbeat != plc_heartbeat_) {
    plc_heartbeat_ = heartbeat;
    plc_heartbeat_changed_ = now;
    plc_heartbeat_lost_ = false;
  }

  // Acknowledge and clear before a trigger written in the same request.
  if (rising(before, after, kCtlResultAck) && result_ready_) {
    result_ready_ = false;
    result_unacked_ = false;
  }
  if (rising(before, after, kCtlClearError)) {
    if (result_error_) result_error_detail_ = 0;  // a no-boxes reason stays with its result
    result_error_ = false;
    missed_trigger_ = false;
    overrun_ = false;
  }
  if (rising(before, after, kCtlTrigger)) start_request(EventKind::kTrigger, control, now, events);
  if (rising(before, after, kCtlPickCheck)) start_request(EventKind::kPickCheck, control, now, events);
  if ((after & (kCtlTrigger | kCtlPickCheck)) == 0) trigger_ack_ = false;
  if (rising(before, after, kCtlSaveSnapshot)) {
    events.push_back(HandshakeEvent{EventKind::kSaveSnapshot, control[kRegRecipe],
                                    control[kRegRequestId], trigger_seq_, now});
  }
  if (rising(before, after, kCtlSetDriftReference)) {
    events.push_back(HandshakeEvent{EventKind::kSetDriftReference, control[kRegRecipe],
                                    control[kRegRequestId], trigger_seq_, now});
  }
  refresh();
  return events;
}

void Handshake::start_request(EventKind kind, const std::uint16_t* control, Clock::time_point now,
                              std::vector<HandshakeEvent>& events) {
  const bool ready = service_.ready && !plc_heartbeat_lost_;
  if (busy_ || !ready) {
    missed_trigger_ = true;
    if (missed_count_ < 0xFFFF) ++missed_count_;
    ++missed_total_;
    return;
  }
  busy_ = true;
  trigger_ack_ = true;
  result_ready_ = false;
  if (kind == EventKind::kTrigger) active_recipe_ = control[kRegRecipe];
  last_request_id_ = control[kRegRequestId];
  trigger_time_ = now;
  ++trigger_seq_;
  HandshakeEvent event{kind, active_recipe_, last_request_id_, trigger_seq_, now};
  if (kind == EventKind::kPickCheck) {
    event.picked_box = control[kRegPickedBox];
    event.picked_group = control[kRegPickedGroup];
  }
  events.push_back(event);
}

void Handshake::on_result(const ResultRecord& result, Clock::time_point now) {
  if (result_unacked_) overrun_ = true;
  result_id_ = static_cast<std::uint16_t>(result_id_ == 0xFFFF ? 1 : result_id_ + 1);
  // Result and pick blocks (with the id in 200, 530, 540 and 902) first, then the status bits:
  // within one register image update, so a reader between requests sees all of it or none of it.
  encode_result(result, result_id_, options_.word_order, image_);
  result_ready_ = true;
  result_unacked_ = true;
  result_error_ = result.status == ResultStatus::kFailed;
  result_error_code_ = result_error_ ? (result.error == ErrorCode::kNone ? ErrorCode::kInternal
                                                                          : result.error)
                                     : ErrorCode::kNone;
  result_error_detail_ = result_error_ ? result.error_detail : static_cast<std::uint16_t>(result.detail);
  processing_ms_ = result.processing_ms;
  if (busy_) {
    latency_ms_ = std::chrono::duration<double, std::milli>(now - trigger_time_).count();
  }
  busy_ = false;
  refresh();
}

void Handshake::on_service_status(const ServiceStatus& status) {
  service_ = status;
  refresh();
}

void Handshake::on_connections(const ConnectionCounters& connections) {
  if (connections == connections_) return;
  connections_ = connections;
  refresh();
}

void Handshake::tick(Clock::time_point now) {
  bool changed = false;
  if (now >= next_heartbeat_) {
    ++heartbeat_;
    next_heartbeat_ += std::chrono::seconds(1);
    if (next_heartbeat_ <= now) next_heartbeat_ = now + std::chrono::seconds(1);  // fell behind
    changed = true;
  }
  if (options_.plc_heartbeat_timeout_s > 0.0 && !plc_heartbeat_lost_ &&
      now - plc_heartbeat_changed_ > seconds(options_.plc_heartbeat_timeout_s)) {
    plc_heartbeat_lost_ = true;
    changed = true;
  }
  if (changed) refresh();
}

Handshake::Clock::time_point Handshake::next_tick() const {
  Clock::time_point next = next_heartbeat_;
  if (options_.plc_heartbeat_timeout_s > 0.0 && !plc_heartbeat_lost_) {
    next = std::min(next, plc_heartbeat_changed_ + seconds(options_.plc_heartbeat_timeout_s) +
                              std::chrono::milliseconds(1));
  }
  return next;
}

}  // namespace palletd::modbus
