// palletd modbus: the PLC handshake of a vision sensor as a pure state machine.
//
// Not thread-safe: one owner (the Modbus server thread) calls every method. No I/O, no clock of
// its own: callers pass the time, so tests drive it deterministically.
//
// Rules (docs/register-map.md has the PLC's view):
// - Trigger, PickCheck, ResultAck, ClearError, SaveSnapshot and SetDriftReference act on their rising edge in
//   the control word; edges written in one request are taken in the order ResultAck, ClearError,
//   Trigger, PickCheck, SaveSnapshot, SetDriftReference.
// - Trigger edge while Ready and not Busy: latch recipe (1) and request id (2) written with it,
//   clear ResultReady, set Busy and TriggerAck, emit a kTrigger event. Otherwise (Busy or not
//   Ready): set MissedTrigger and count it (112); no event.
// - PickCheck edge: the same, latching the request id (2) and the picked box (4) and group (5)
//   instead of the recipe, and emitting a kPickCheck event; its result answers the check.
// - TriggerAck clears when neither Trigger nor PickCheck is set any more.
// - A result (on_result): if the previous result was never acknowledged, set ResultOverrun; encode
//   the result block with the next result id (1..65535, wrapping past 0), then set ResultReady,
//   set/clear the result error (Error bit, 101/102) from the result status, clear Busy.
// - ResultAck edge: clear ResultReady. ClearError edge: clear the latched result error,
//   MissedTrigger and ResultOverrun (live errors such as a lost camera stay until they go away).
// - SaveSnapshot edge: emit a kSaveSnapshot event. SetDriftReference edge: emit a
//   kSetDriftReference event.
// - HealthWarning and DriftWarning (status word bits 9, 10) follow the service's health record.
// - Heartbeat counter (103) +1 every second, HeartbeatToggle = its lowest bit.
// - PLC heartbeat watch (optional): register 3 unchanged for longer than the timeout -> error
//   kPlcHeartbeatLost and Ready cleared until it changes again.
// Error code priority (101): PLC heartbeat lost, then the service's live error, then the last
// result's error.
#pragma once

#include <chrono>
#include <cstdint>
#include <vector>

#include "palletd/modbus/register_map.hpp"

namespace palletd::modbus {

struct HandshakeOptions {
  WordOrder word_order = WordOrder::kHighWordFirst;
  double plc_heartbeat_timeout_s = 0.0;  ///< 0 = no watch
  std::uint16_t initial_recipe = 1;      ///< register 104 before the first trigger
};

/// The service's live state, shown in the status block.
struct ServiceStatus {
  bool ready = false;      ///< the service accepts triggers (pipeline up)
  bool camera_ok = false;  ///< camera connected and delivering frames
  ErrorCode error = ErrorCode::kNone;  ///< a live condition (e.g. camera disconnected)
  std::uint16_t error_detail = 0;
  std::uint16_t acquisition_id = 0;  ///< sequence number of the newest frame (low 16 bits)
  std::uint32_t frames_grabbed = 0;
  std::uint16_t camera_reconnects = 0;
  CameraFaultCounters camera_faults;   ///< registers 118..129
  bool poses_in_camera_frame = false;  ///< no camera_to_base configured
  HealthRecord health;                 ///< registers 146..155, status word bits 9 and 10
};

enum class EventKind : std::uint8_t { kTrigger, kPickCheck, kSaveSnapshot, kSetDriftReference };

struct HandshakeEvent {
  EventKind kind = EventKind::kTrigger;
  std::uint16_t recipe = 0;      ///< latched with the trigger (current register 1 for snapshots)
  std::uint16_t request_id = 0;  ///< latched with the trigger (current register 2 for snapshots)
  std::uint64_t trigger_seq = 0; ///< 1, 2, ... per accepted trigger or check (last one for snapshots)
  std::chrono::steady_clock::time_point time;  ///< when the edge was seen
  std::uint16_t picked_box = 0;    ///< kPickCheck: register 4 latched with the edge (slot + 1, 0 = none)
  std::uint16_t picked_group = 0;  ///< kPickCheck: register 5 latched with the edge (slot + 1, 0 = none)
};

class Handshake {
 public:
  using Clock = std::chrono::steady_clock;

  Handshake(const HandshakeOptions& options, Clock::time_point now);

  /// The PLC wrote the control block; `control` holds all kControlCount registers after the write.
  std::vector<HandshakeEvent> on_control_written(const std::uint16_t* control, Clock::time_point now);
  /// The service finished a detection (or failed one).
  void on_result(const ResultRecord& result, Clock::time_point now);
  void on_service_status(const ServiceStatus& status);
  /// The server's connection counters (registers 140..145); changes the image only when they differ.
  void on_connections(const ConnectionCounters& connections);
  /// Advances the heartbeat and the PLC heartbeat watch.
  void tick(Clock::time_point now);
  /// When tick() next has something to do.
  [[nodiscard]] Clock::time_point next_tick() const;

  /// Control, status and result blocks as the PLC reads them.
  [[nodiscard]] const RegisterImage& registers() const { return image_; }
  /// Increases whenever registers() changes.
  [[nodiscard]] std::uint64_t version() const { return version_; }
  [[nodiscard]] std::uint16_t status_word() const;
  [[nodiscard]] bool busy() const { return busy_; }
  [[nodiscard]] std::uint16_t result_id() const { return result_id_; }
  /// Triggers refused while Busy or not Ready since start (register 112 saturates at 65535).
  [[nodiscard]] std::uint64_t missed_total() const { return missed_total_; }
  [[nodiscard]] bool plc_heartbeat_lost() const { return plc_heartbeat_lost_; }

 private:
  void refresh();
  /// A Trigger or PickCheck edge: accepted (Busy, an event) when Ready and not Busy, else missed.
  void start_request(EventKind kind, const std::uint16_t* control, Clock::time_point now,
                     std::vector<HandshakeEvent>& events);

  HandshakeOptions options_;
  RegisterImage image_{};
  std::uint64_t version_ = 0;
  ServiceStatus service_;
  ConnectionCounters connections_;

  std::uint16_t prev_control_word_ = 0;
  bool busy_ = false;
  bool trigger_ack_ = false;
  bool result_ready_ = false;
  bool result_unacked_ = false;
  bool missed_trigger_ = false;
  bool overrun_ = false;
  bool result_error_ = false;
  ErrorCode result_error_code_ = ErrorCode::kNone;
  std::uint16_t result_error_detail_ = 0;
  std::uint16_t missed_count_ = 0;
  std::uint64_t missed_total_ = 0;
  std::uint16_t result_id_ = 0;
  std::uint16_t last_request_id_ = 0;
  std::uint16_t active_recipe_ = 0;
  std::uint64_t trigger_seq_ = 0;
  Clock::time_point trigger_time_;
  double processing_ms_ = 0.0;
  double latency_ms_ = 0.0;

  std::uint16_t heartbeat_ = 0;
  Clock::time_point next_heartbeat_;
  std::uint16_t plc_heartbeat_ = 0;
  Clock::time_point plc_heartbeat_changed_;
  bool plc_heartbeat_lost_ = false;
};

}  // namespace palletd::modbus
