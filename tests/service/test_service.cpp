// The service end to end: replay camera -> pipeline -> Modbus server, driven by a real Modbus TCP
// client over loopback doing the PLC's handshake.
#include <chrono>
#include <filesystem>
#include <thread>

#include <catch2/catch.hpp>
#include <unistd.h>

#include "palletd/config/config.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/service/service.hpp"

#include "service_fixtures.hpp"

using namespace std::chrono_literals;
using palletd::modbus::ErrorCode;
using palletd::modbus::ResultStatus;
using namespace palletd::service_test;

TEST_CASE("a trigger over Modbus is answered with the detection of the replayed frame") {
  const auto names = bundled_stems(1);
  TempFrames frames(names);
  palletd::Config config = demo_config(frames.dir);
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  const std::uint16_t port = service.health().modbus_port;
  REQUIRE(port != 0);

  palletd::modbus::PlcClient plc("127.0.0.1", port, config.modbus.unit_id);
  REQUIRE(plc.connect().ok());
  auto result = plc.trigger(static_cast<std::uint16_t>(config.recipes.front().number), 4242, 10s);
  REQUIRE(result.ok());
  const auto& rec = result->result.record;
  CHECK(rec.request_id == 4242);
  CHECK(rec.recipe == config.recipes.front().number);

  // The same frame through detect() directly gives the same boxes.
  auto frame = palletd::read_frame((frames.dir / names[0]).string());
  REQUIRE(frame.ok());
  std::vector<palletd::BoxFormat> formats;
  for (int i : config.recipes.front().formats) formats.push_back(config.formats[static_cast<std::size_t>(i)]);
  const palletd::Detection direct = palletd::detect(*frame, formats, config.detection);
  const auto snapshot = service.latest();
  REQUIRE(snapshot != nullptr);
  CHECK(snapshot->request_id == 4242);
  CHECK(snapshot->detection.status == direct.status);
  REQUIRE(rec.boxes_found == direct.boxes.size());
  for (std::size_t i = 0; i < std::min<std::size_t>(direct.boxes.size(), 32); ++i) {
    // Camera frame (no camera_to_base in this config): 0.1 mm resolution on the wire.
    const auto& want = direct.boxes[i];
    const auto& got = rec.boxes[i];
    const Eigen::Vector3d p = want.base_position ? *want.base_position : want.center;
    CHECK(got.x_m == Approx(p.x()).margin(1e-4));
    CHECK(got.y_m == Approx(p.y()).margin(1e-4));
    CHECK(got.z_m == Approx(p.z()).margin(1e-4));
    CHECK(got.pick_index == want.pick_index + 1);
  }
  service.stop();
}

TEST_CASE("with a gripper the pick block over Modbus holds the detection's groups and box statuses") {
  const auto names = bundled_stems(1);
  TempFrames frames(names);
  palletd::Config config = demo_config(frames.dir);
  const palletd::BoxFormat& format = config.formats[static_cast<std::size_t>(config.recipes.front().formats.front())];
  palletd::GripperParams gripper;
  gripper.footprint_mm = Eigen::Vector2d(1e3 * format.long_m, 1e3 * format.short_m);
  config.detection.gripper = gripper;
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, config.modbus.unit_id);
  REQUIRE(plc.connect().ok());
  auto result = plc.trigger(static_cast<std::uint16_t>(config.recipes.front().number), 77, 10s);
  REQUIRE(result.ok());
  REQUIRE(result->result.ids_agree());  // 200 = 530 = 540 = 902
  const auto& rec = result->result.record;
  const auto snapshot = service.latest();  // this result's as ResultReady rose
  REQUIRE(snapshot != nullptr);
  CHECK(snapshot->request_id == 77);
  const palletd::Detection& d = snapshot->detection;
  REQUIRE(d.status == palletd::DetectionStatus::kOk);
  CHECK(rec.picking);
  REQUIRE(rec.groups.size() == d.groups.size());
  CHECK(rec.groups_found == d.groups.size());
  for (std::size_t g = 0; g < d.groups.size(); ++g) {
    CHECK(rec.groups[g].x_m == Approx(d.groups[g].tcp.position_m.x()).margin(1e-4));
    CHECK(rec.groups[g].first_box == d.groups[g].boxes.front());
    CHECK(rec.groups[g].box_count == d.groups[g].boxes.size());
    CHECK(rec.groups[g].pick_index == d.groups[g].pick_index + 1);
  }
  int pickable = 0;
  for (std::size_t i = 0; i < rec.boxes.size(); ++i) {
    REQUIRE(d.boxes[i].pick);
    pickable += d.boxes[i].pick->pickable ? 1 : 0;
    CHECK((rec.boxes[i].pick_status == palletd::modbus::PickStatus::kPickable) == d.boxes[i].pick->pickable);
  }
  CHECK(rec.pickable_boxes == pickable);
  CHECK(pickable >= 1);
  service.stop();
}

TEST_CASE("a camera that is gone fails the trigger, drops CameraOK, and recovers when it returns") {
  TempFrames frames(bundled_stems(1));
  palletd::Config config = demo_config(frames.dir);
  config.camera.reconnect_min_s = 0.05;
  config.camera.reconnect_max_s = 0.2;
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  const auto recipe = static_cast<std::uint16_t>(config.recipes.front().number);
  REQUIRE(plc.trigger(recipe, 1, 10s).ok());

  const fs::path moved = frames.dir.string() + ".away";
  fs::rename(frames.dir, moved);
  auto failed = plc.trigger(recipe, 2, 10s);
  REQUIRE(failed.ok());
  CHECK(failed->result.record.status == ResultStatus::kFailed);
  CHECK((failed->status.error == ErrorCode::kCameraDisconnected || failed->status.error == ErrorCode::kFrameTimeout));
  // CameraOK drops in the status block.
  palletd::modbus::RegisterImage image{};
  bool camera_ok_dropped = false;
  for (int i = 0; i < 100 && !camera_ok_dropped; ++i) {
    REQUIRE(plc.read(palletd::modbus::kStatusStart, palletd::modbus::kStatusCount, image).ok());
    camera_ok_dropped = (image[palletd::modbus::kRegStatusWord] & palletd::modbus::kStCameraOk) == 0;
    std::this_thread::sleep_for(20ms);
  }
  CHECK(camera_ok_dropped);

  fs::rename(moved, frames.dir);
  std::this_thread::sleep_for(300ms);
  auto recovered = plc.trigger(recipe, 3, 10s);
  REQUIRE(recovered.ok());
  // The frame is back: whatever detection says, the camera error is gone.
  CHECK(recovered->status.error != ErrorCode::kCameraDisconnected);
  CHECK(recovered->status.error != ErrorCode::kFrameTimeout);
  CHECK((recovered->status.status_word & palletd::modbus::kStCameraOk) != 0);
  const palletd::ServiceHealth health = service.health();
  CHECK(health.reconnects >= 1);
  // The loss is counted in the health and in the status registers 124-125 alike.
  CHECK(health.camera_losses >= 1);
  CHECK(health.camera_losses >= health.reconnects);
  CHECK(recovered->status.camera_faults.camera_losses >= 1);
  CHECK(recovered->status.camera_faults.camera_losses <= health.camera_losses);
  CHECK(recovered->status.camera_faults.incomplete_frames <= health.incomplete_frames);
}

TEST_CASE("a trigger while Busy sets MissedTrigger and counts, result ids advance per result") {
  // A free-running camera at 0.5 Hz keeps the pipeline Busy until the frame timeout (the answer
  // must be a frame captured after the trigger).
  TempFrames frames(bundled_stems(1));
  palletd::Config config = demo_config(frames.dir);
  config.camera.replay.rate_hz = 0.5;
  config.camera.frame_timeout_ms = 800;
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  palletd::modbus::RegisterImage image{};
  auto status_word = [&] {
    REQUIRE(plc.read(palletd::modbus::kStatusStart, palletd::modbus::kStatusCount, image).ok());
    return image[palletd::modbus::kRegStatusWord];
  };
  for (int i = 0; i < 100 && (status_word() & palletd::modbus::kStReady) == 0; ++i) std::this_thread::sleep_for(10ms);
  const std::uint16_t trigger[3] = {palletd::modbus::kCtlTrigger, 1, 5};
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, trigger, 3).ok());
  CHECK((status_word() & palletd::modbus::kStBusy) != 0);
  const std::uint16_t zero = 0;
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &zero, 1).ok());
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, trigger, 3).ok());  // while Busy
  const std::uint16_t word = status_word();
  CHECK((word & palletd::modbus::kStMissedTrigger) != 0);
  CHECK(image[palletd::modbus::kRegMissedTriggers] == 1);
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &zero, 1).ok());
  // The first trigger ends in a frame timeout: result id 1, failed.
  bool ready = false;
  for (int i = 0; i < 300 && !ready; ++i) {
    ready = (status_word() & palletd::modbus::kStResultReady) != 0;
    if (!ready) std::this_thread::sleep_for(10ms);
  }
  REQUIRE(ready);
  CHECK(image[palletd::modbus::kRegStatusResultId] == 1);
  CHECK(image[palletd::modbus::kRegErrorCode] == static_cast<std::uint16_t>(ErrorCode::kFrameTimeout));
  const std::uint16_t ack = palletd::modbus::kCtlResultAck;
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &ack, 1).ok());
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &zero, 1).ok());
  auto second = plc.trigger(1, 6, 10s);
  REQUIRE(second.ok());
  CHECK(second->result.result_id == 2);
  CHECK(second->result.record.request_id == 6);
}

TEST_CASE("SaveSnapshot stores the next triggered frame with its result and overlay") {
  TempFrames frames(bundled_stems(1));
  palletd::Config config = demo_config(frames.dir);
  const fs::path recordings = frames.dir / "recordings";
  config.recording.enabled = true;
  config.recording.directory = recordings.string();
  config.recording.every_trigger = false;
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  const auto recipe = static_cast<std::uint16_t>(config.recipes.front().number);
  // Without the bit nothing is recorded.
  REQUIRE(plc.trigger(recipe, 1, 10s).ok());
  auto count = [&](const std::string& suffix) {
    std::size_t n = 0;
    if (!fs::exists(recordings)) return n;
    for (const auto& e : fs::directory_iterator(recordings)) {
      const std::string name = e.path().filename().string();
      if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) ++n;
    }
    return n;
  };
  CHECK(count(".depth.png") == 0);
  const std::uint16_t snapshot = palletd::modbus::kCtlSaveSnapshot, zero = 0;
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &snapshot, 1).ok());
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &zero, 1).ok());
  std::this_thread::sleep_for(300ms);  // the event reaches the pipeline
  REQUIRE(plc.trigger(recipe, 2, 10s).ok());
  for (int i = 0; i < 100 && count(".depth.png") == 0; ++i) std::this_thread::sleep_for(20ms);
  CHECK(count(".depth.png") == 1);
  CHECK(count(".json") >= 2);  // frame metadata and the detection
  CHECK(count(".overlay.png") == 1);
  // And over the service API (the status page's POST).
  CHECK(service.request_snapshot().ok());
  REQUIRE(plc.trigger(recipe, 3, 10s).ok());
  for (int i = 0; i < 100 && count(".depth.png") < 2; ++i) std::this_thread::sleep_for(20ms);
  CHECK(count(".depth.png") == 2);
}

TEST_CASE("a shadow configuration runs after every result, counts where it differs and records those frames") {
  const auto names = bundled_stems(1);
  TempFrames frames(names);
  palletd::Config config = demo_config(frames.dir);
  const fs::path recordings = frames.dir / "recordings";
  config.recording.enabled = true;
  config.recording.directory = recordings.string();
  // The same recipe number with the other format: the shadow's layout differs from the live one.
  const int recipe = config.recipes.front().number;
  auto shadow = std::make_shared<palletd::Config>(config);
  shadow->recipes.front().formats = {config.recipes[1].formats.front()};
  REQUIRE(shadow->recipes.front().formats != config.recipes.front().formats);
  config.shadow = shadow;
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  CHECK(service.health().shadow_enabled);
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  // The shadow runs at idle priority: beside other tests on both cores it waits until a core is
  // free, so the wait is long (it ends as soon as the run is counted).
  const auto wait_runs = [&service](std::uint64_t runs) {
    const auto until = std::chrono::steady_clock::now() + 60s * PALLETD_TEST_TIME_SCALE;
    while (std::chrono::steady_clock::now() < until &&
           service.health().shadow_runs + service.health().shadow_skipped < runs)
      std::this_thread::sleep_for(10ms);
  };
  REQUIRE(plc.trigger(static_cast<std::uint16_t>(recipe), 1, 10s).ok());
  wait_runs(1);
  palletd::ServiceHealth h = service.health();
  CHECK(h.shadow_runs == 1);
  CHECK(h.shadow_disagreements == 1);
  CHECK(h.last_shadow_difference.rfind("trigger ", 0) == 0);
  const auto recorded = palletd::list_frame_stems((recordings / "shadow").string());
  REQUIRE(recorded.ok());
  CHECK(recorded->size() == 1);

  // The live configuration as the shadow: no disagreement. A recipe the shadow lacks is skipped.
  palletd::Config same = config;
  same.shadow = std::make_shared<palletd::Config>(demo_config(frames.dir));
  service.reload(same);
  REQUIRE(plc.trigger(static_cast<std::uint16_t>(recipe), 2, 10s).ok());
  wait_runs(2);
  h = service.health();
  CHECK(h.shadow_runs == 2);
  CHECK(h.shadow_disagreements == 1);
  auto no_recipes = std::make_shared<palletd::Config>(demo_config(frames.dir));
  no_recipes->recipes.clear();
  same.shadow = no_recipes;
  service.reload(same);
  REQUIRE(plc.trigger(static_cast<std::uint16_t>(recipe), 3, 10s).ok());
  wait_runs(3);
  CHECK(service.health().shadow_skipped == 1);
  service.stop();
}
