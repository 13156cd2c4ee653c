#include <catch2/catch.hpp>

#include <array>

#include "palletd/modbus/handshake.hpp"

using namespace palletd::modbus;
using Clock = Handshake::Clock;
using std::chrono::milliseconds;

namespace {

struct Plc {
  std::array<std::uint16_t, kControlCount> control{};
  Handshake& hs;
  Clock::time_point& now;

  std::vector<HandshakeEvent> write(std::uint16_t word, std::uint16_t recipe, std::uint16_t request) {
    control[kRegControlWord] = word;
    control[kRegRecipe] = recipe;
    control[kRegRequestId] = request;
    return hs.on_control_written(control.data(), now);
  }
  std::vector<HandshakeEvent> word(std::uint16_t w) {
    control[kRegControlWord] = w;
    return hs.on_control_written(control.data(), now);
  }
  [[nodiscard]] std::uint16_t status() const { return hs.registers()[kRegStatusWord]; }
};

ServiceStatus ready_status() {
  ServiceStatus s;
  s.ready = true;
  s.camera_ok = true;
  return s;
}

ResultRecord ok_result(std::uint16_t request, int boxes) {
  ResultRecord r;
  r.request_id = request;
  r.recipe = 2;
  r.status = boxes > 0 ? ResultStatus::kOk : ResultStatus::kNoBoxes;
  r.boxes_found = static_cast<std::uint16_t>(boxes);
  for (int i = 0; i < boxes; ++i) r.boxes.push_back(BoxRecord{0.1 * i, 0.2, 1.0, 5.0, 0, 0.9, static_cast<std::uint16_t>(i + 1)});
  r.processing_ms = 42.0;
  return r;
}

}  // namespace

TEST_CASE("a full trigger / result / acknowledge cycle", "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  CHECK((plc.status() & kStReady) == 0);
  hs.on_service_status(ready_status());
  CHECK(plc.status() == (kStReady | kStCameraOk));
  CHECK(hs.registers()[kRegActiveRecipe] == 1);

  auto events = plc.write(kCtlTrigger, 2, 1001);
  REQUIRE(events.size() == 1);
  CHECK(events[0].kind == EventKind::kTrigger);
  CHECK(events[0].recipe == 2);
  CHECK(events[0].request_id == 1001);
  CHECK(events[0].trigger_seq == 1);
  CHECK((plc.status() & (kStBusy | kStTriggerAck)) == (kStBusy | kStTriggerAck));
  CHECK(hs.registers()[kRegLastRequestId] == 1001);
  CHECK(hs.registers()[kRegActiveRecipe] == 2);
  // Writing the trigger again without a falling edge is no new trigger.
  CHECK(plc.write(kCtlTrigger, 2, 1001).empty());

  CHECK(plc.word(0).empty());
  CHECK((plc.status() & kStTriggerAck) == 0);
  CHECK((plc.status() & kStBusy) != 0);

  now += milliseconds(250);
  hs.on_result(ok_result(1001, 3), now);
  CHECK((plc.status() & (kStBusy | kStResultReady | kStError)) == kStResultReady);
  CHECK(hs.registers()[kRegResultId] == 1);
  CHECK(hs.registers()[kResultIdCopy] == 1);
  CHECK(hs.registers()[kRegStatusResultId] == 1);
  CHECK(hs.registers()[kRegResultRequestId] == 1001);
  CHECK(hs.registers()[kRegBoxesReported] == 3);
  CHECK(hs.registers()[kRegLatencyMs] == 250);
  CHECK(hs.registers()[kRegProcessingMs] == 42);

  plc.word(kCtlResultAck);
  CHECK((plc.status() & kStResultReady) == 0);
  plc.word(0);

  // Second cycle: the trigger clears nothing it should not, result id counts up.
  events = plc.write(kCtlTrigger, 3, 1002);
  REQUIRE(events.size() == 1);
  CHECK(events[0].trigger_seq == 2);
  hs.on_result(ok_result(1002, 0), now);
  CHECK(hs.registers()[kRegResultId] == 2);
  CHECK(hs.registers()[kRegResultStatus] == 1);
  CHECK((plc.status() & kStResultOverrun) == 0);
}

TEST_CASE("triggers while busy or not ready are missed and counted", "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  CHECK(plc.write(kCtlTrigger, 1, 1).empty());  // not ready
  CHECK((plc.status() & kStMissedTrigger) != 0);
  CHECK(hs.registers()[kRegMissedTriggers] == 1);
  plc.word(0);
  hs.on_service_status(ready_status());
  REQUIRE(plc.write(kCtlTrigger, 1, 2).size() == 1);
  plc.word(0);
  CHECK(plc.write(kCtlTrigger, 1, 3).empty());  // busy
  CHECK(hs.registers()[kRegMissedTriggers] == 2);
  CHECK(hs.registers()[kRegLastRequestId] == 2);  // the missed one did not latch
  CHECK((plc.status() & kStTriggerAck) == 0);
  plc.word(kCtlClearError);
  CHECK((plc.status() & kStMissedTrigger) == 0);
  CHECK(hs.registers()[kRegMissedTriggers] == 2);  // the count stays
}

TEST_CASE("failed results set Error until ClearError or a good result", "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  hs.on_service_status(ready_status());
  plc.write(kCtlTrigger, 1, 7);
  ResultRecord failed;
  failed.request_id = 7;
  failed.status = ResultStatus::kFailed;
  failed.error = ErrorCode::kDetectionFailed;
  failed.error_detail = static_cast<std::uint16_t>(DetectionFailure::kNoPlane);
  hs.on_result(failed, now);
  CHECK((plc.status() & (kStError | kStResultReady)) == (kStError | kStResultReady));
  CHECK(hs.registers()[kRegErrorCode] == 3);
  CHECK(hs.registers()[kRegErrorDetail] == 1);
  CHECK(hs.registers()[kRegResultStatus] == 2);
  plc.word(kCtlClearError);
  CHECK((plc.status() & kStError) == 0);
  CHECK(hs.registers()[kRegErrorCode] == 0);

  // A live service error shows while it lasts and ClearError cannot hide it.
  ServiceStatus gone = ready_status();
  gone.camera_ok = false;
  gone.error = ErrorCode::kCameraDisconnected;
  gone.error_detail = 3;
  hs.on_service_status(gone);
  CHECK((plc.status() & (kStError | kStCameraOk)) == kStError);
  plc.word(0);
  plc.word(kCtlClearError);
  CHECK(hs.registers()[kRegErrorCode] == 4);
  hs.on_service_status(ready_status());
  CHECK((plc.status() & (kStError | kStCameraOk)) == kStCameraOk);
}

TEST_CASE("a result without boxes says why in 102 and 130, without Error", "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  hs.on_service_status(ready_status());
  plc.write(kCtlTrigger, 1, 8);
  ResultRecord sheet;
  sheet.request_id = 8;
  sheet.status = ResultStatus::kNoBoxes;
  sheet.detail = ResultDetail::kSlipSheet;
  hs.on_result(sheet, now);
  CHECK((plc.status() & (kStError | kStResultReady)) == kStResultReady);
  CHECK(hs.registers()[kRegErrorCode] == 0);
  CHECK(hs.registers()[kRegErrorDetail] == 6);
  CHECK(hs.registers()[kRegResultDetail] == 6);
  CHECK(hs.registers()[kRegResultStatus] == 1);
  // ClearError does not clear a reason that belongs to the result in the block.
  plc.word(kCtlClearError);
  CHECK(hs.registers()[kRegErrorDetail] == 6);
  // The next result replaces it.
  plc.word(0);
  plc.write(kCtlTrigger, 1, 9);
  hs.on_result(ok_result(9, 2), now);
  CHECK(hs.registers()[kRegErrorDetail] == 0);
  CHECK(hs.registers()[kRegResultDetail] == 0);
}

TEST_CASE("a result replacing an unacknowledged one sets ResultOverrun", "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  hs.on_service_status(ready_status());
  plc.write(kCtlTrigger, 1, 1);
  hs.on_result(ok_result(1, 1), now);
  plc.word(0);
  plc.write(kCtlTrigger, 1, 2);  // no ResultAck for result 1
  CHECK((plc.status() & kStResultReady) == 0);  // the trigger cleared it
  hs.on_result(ok_result(2, 1), now);
  CHECK((plc.status() & kStResultOverrun) != 0);
  plc.word(kCtlResultAck);
  CHECK((plc.status() & kStResultOverrun) != 0);  // sticky until ClearError
  plc.word(kCtlClearError);
  CHECK((plc.status() & kStResultOverrun) == 0);
}

TEST_CASE("ResultAck and ClearError written together with the next Trigger act first",
          "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  hs.on_service_status(ready_status());
  plc.write(kCtlTrigger, 1, 1);
  plc.write(kCtlTrigger, 1, 2);  // no edge: nothing happens
  plc.word(0);
  plc.write(kCtlTrigger, 1, 3);  // busy: missed
  plc.word(0);
  hs.on_result(ok_result(1, 1), now);
  REQUIRE((plc.status() & (kStResultReady | kStMissedTrigger)) == (kStResultReady | kStMissedTrigger));
  const auto events = plc.write(kCtlTrigger | kCtlResultAck | kCtlClearError, 1, 4);
  REQUIRE(events.size() == 1);
  CHECK(events[0].request_id == 4);
  CHECK((plc.status() & (kStMissedTrigger | kStBusy)) == kStBusy);
  plc.word(0);
  hs.on_result(ok_result(4, 1), now);
  CHECK((plc.status() & kStResultOverrun) == 0);  // result 1 was acknowledged
}

TEST_CASE("SaveSnapshot is reported on its rising edge", "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  auto events = plc.write(kCtlSaveSnapshot, 5, 99);
  REQUIRE(events.size() == 1);
  CHECK(events[0].kind == EventKind::kSaveSnapshot);
  CHECK(events[0].recipe == 5);
  CHECK(plc.word(kCtlSaveSnapshot).empty());
}

TEST_CASE("heartbeat counts seconds and the PLC heartbeat watch", "[modbus][handshake]") {
  Clock::time_point now{};
  HandshakeOptions options;
  options.plc_heartbeat_timeout_s = 2.0;
  Handshake hs(options, now);
  Plc plc{{}, hs, now};
  hs.on_service_status(ready_status());
  CHECK(hs.next_tick() == now + std::chrono::seconds(1));
  for (int i = 0; i < 10; ++i) {
    now += milliseconds(500);
    plc.control[kRegPlcHeartbeat] = static_cast<std::uint16_t>(i);
    plc.word(0);
    hs.tick(now);
  }
  CHECK(hs.registers()[kRegHeartbeat] == 5);
  CHECK((plc.status() & kStHeartbeatToggle) != 0);
  CHECK((plc.status() & kStReady) != 0);
  now += milliseconds(2100);
  hs.tick(now);
  CHECK((plc.status() & (kStReady | kStError)) == kStError);
  CHECK(hs.registers()[kRegErrorCode] == static_cast<std::uint16_t>(ErrorCode::kPlcHeartbeatLost));
  CHECK(plc.write(kCtlTrigger, 1, 1).empty());  // not ready -> missed
  plc.control[kRegPlcHeartbeat] = 1234;
  plc.word(0);
  CHECK((plc.status() & (kStReady | kStError)) == kStReady);
}

TEST_CASE("the service's camera fault counters reach registers 118..129 in the configured word order",
          "[modbus][handshake]") {
  Clock::time_point now{};
  HandshakeOptions options;
  options.word_order = WordOrder::kLowWordFirst;
  Handshake hs(options, now);
  ServiceStatus s = ready_status();
  s.camera_faults.incomplete_frames = 0x00020001u;
  s.camera_faults.grab_timeouts = 3;
  s.camera_faults.camera_losses = 4;
  s.camera_faults.camera_restarts = 5;
  hs.on_service_status(s);
  const RegisterImage& r = hs.registers();
  CHECK(r[kRegIncompleteFrames] == 0x0001);  // low word first
  CHECK(r[kRegIncompleteFrames + 1] == 0x0002);
  CHECK(r[kRegGrabTimeouts] == 3);
  CHECK(decode_status(r, WordOrder::kLowWordFirst).camera_faults == s.camera_faults);
  // A later status replaces the counters (they are the service's, not latched by the handshake).
  s.camera_faults.grab_timeouts = 9;
  hs.on_service_status(s);
  CHECK(hs.registers()[kRegGrabTimeouts] == 9);
}

TEST_CASE("HealthWarning and DriftWarning follow the service's health flags, SetDriftReference is an event",
          "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  ServiceStatus s = ready_status();
  hs.on_service_status(s);
  CHECK((plc.status() & (kStHealthWarning | kStDriftWarning)) == 0);
  s.health.flags = kHealthSaturated | kHealthDriftReference | kHealthDriftMeasured;
  hs.on_service_status(s);
  CHECK((plc.status() & (kStHealthWarning | kStDriftWarning)) == kStHealthWarning);
  CHECK(hs.registers()[kRegHealthFlags] == s.health.flags);
  s.health.flags = kHealthDrift | kHealthDriftReference | kHealthDriftMeasured;
  hs.on_service_status(s);
  CHECK((plc.status() & (kStHealthWarning | kStDriftWarning)) == kStDriftWarning);
  // Warnings are not errors: the cell keeps picking.
  CHECK((plc.status() & (kStError | kStReady)) == kStReady);

  auto events = plc.write(kCtlSetDriftReference, 1, 5);
  REQUIRE(events.size() == 1);
  CHECK(events[0].kind == EventKind::kSetDriftReference);
  CHECK(plc.write(kCtlSetDriftReference, 1, 5).empty());  // held high: no second edge
}

TEST_CASE("PickCheck is a request like Trigger: it latches the picked box and group, keeps the recipe",
          "[modbus][handshake]") {
  Clock::time_point now{};
  Handshake hs(HandshakeOptions{}, now);
  Plc plc{{}, hs, now};
  hs.on_service_status(ready_status());
  REQUIRE(plc.write(kCtlTrigger, 3, 100).size() == 1);
  plc.word(0);
  hs.on_result(ok_result(100, 4), now);
  plc.word(kCtlResultAck);
  plc.word(0);

  plc.control[kRegPickedBox] = 0;
  plc.control[kRegPickedGroup] = 2;
  auto events = plc.write(kCtlPickCheck, 9, 101);  // register 1 is not latched by a check
  REQUIRE(events.size() == 1);
  CHECK(events[0].kind == EventKind::kPickCheck);
  CHECK(events[0].picked_box == 0);
  CHECK(events[0].picked_group == 2);
  CHECK(events[0].request_id == 101);
  CHECK(events[0].recipe == 3);
  CHECK(events[0].trigger_seq == 2);
  CHECK(hs.registers()[kRegActiveRecipe] == 3);
  CHECK((plc.status() & (kStBusy | kStTriggerAck)) == (kStBusy | kStTriggerAck));
  CHECK((plc.status() & kStResultReady) == 0);

  // A second request while the check runs is missed, whichever bit it comes on.
  CHECK(plc.word(kCtlPickCheck | kCtlTrigger).empty());
  CHECK(plc.word(0).empty());
  CHECK((plc.status() & kStTriggerAck) == 0);  // neither bit set any more
  CHECK(hs.missed_total() == 1);

  ResultRecord checked = ok_result(101, 3);
  checked.check = CheckRecord{CheckResult::kNeighbourMoved, 1, 1, 2, 0.0213};
  hs.on_result(checked, now);
  CHECK((plc.status() & (kStBusy | kStResultReady)) == kStResultReady);
  CHECK(hs.registers()[kRegCheckResult] == 4);
  CHECK(hs.registers()[kRegCheckBoxesGone] == 1);
  CHECK(hs.registers()[kRegCheckMovedSlot] == 2);
  CHECK(hs.registers()[kRegCheckLargestMove] == 213);
  hs.on_result(ok_result(102, 3), now);  // the next detection clears 135..139
  CHECK(hs.registers()[kRegCheckResult] == 0);
  CHECK(hs.registers()[kRegCheckLargestMove] == 0);
}
