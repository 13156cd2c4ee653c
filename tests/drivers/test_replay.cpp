// The camera state machine, the replay driver, the factory and the supervisor's reconnect.
#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "drivers_test_util.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/config/config.hpp"
#include "palletd/frames/frame_io.hpp"

using namespace palletd;
using palletd::test::synthetic_frame;
using palletd::test::TempDir;
using std::chrono::milliseconds;

namespace {

void write_frames(const TempDir& dir, const std::vector<std::string>& names, int width = 32, int height = 24) {
  std::uint32_t seed = 1;
  for (const auto& name : names) {
    Status s = write_frame((dir.path() / name).string(), synthetic_frame(width, height, seed++));
    REQUIRE(s.ok());
  }
}

CameraConfig replay_config(const TempDir& dir, bool loop, double rate_hz) {
  CameraConfig c;
  c.driver = "replay";
  c.replay.directory = dir.str();
  c.replay.loop = loop;
  c.replay.rate_hz = rate_hz;
  c.reconnect_min_s = 0.02;
  c.reconnect_max_s = 0.08;
  return c;
}

}  // namespace

TEST_CASE("camera state machine refuses out-of-order calls and the constructor does no I/O") {
  TempDir dir("state");
  // The folder does not exist yet: constructing must still succeed (no I/O).
  CameraConfig c = replay_config(dir, true, 0.0);
  c.replay.directory = (dir.path() / "later").string();
  auto cam = make_camera(c);
  REQUIRE(cam);
  CHECK(cam->state() == CameraState::kClosed);
  CHECK_FALSE(cam->start().ok());
  CHECK_FALSE(cam->grab(milliseconds(1)).ok());
  CHECK(cam->last_error().find("closed") != std::string::npos);

  Status opened = cam->open();
  CHECK_FALSE(opened.ok());
  CHECK(opened.error().find("later") != std::string::npos);  // names the missing folder
  CHECK(cam->state() == CameraState::kClosed);

  std::filesystem::create_directories(dir.path() / "later");
  REQUIRE(write_frame((dir.path() / "later" / "f0").string(), synthetic_frame(16, 12, 3)).ok());
  REQUIRE(cam->open().ok());
  CHECK(cam->state() == CameraState::kOpen);
  CHECK_FALSE(cam->open().ok());  // already open
  CHECK_FALSE(cam->grab(milliseconds(1)).ok());
  REQUIRE(cam->start().ok());
  CHECK(cam->state() == CameraState::kStreaming);
  REQUIRE(cam->stop().ok());
  CHECK(cam->state() == CameraState::kOpen);
  cam->close();
  CHECK(cam->state() == CameraState::kClosed);
  CHECK(cam->identity().driver == "replay");
}

TEST_CASE("factory rejects unknown drivers and impossible configurations") {
  CameraConfig c;
  c.driver = "nonsense";
  CHECK_THROWS_WITH(make_camera(c), Catch::Contains("nonsense"));
  c.driver = "replay";
  CHECK_THROWS_WITH(make_camera(c), Catch::Contains("directory"));
  c.driver = "aravis";
  c.aravis.address = "192.0.2.10";
  c.aravis.pixel_format = "RGB8";
  CHECK_THROWS_WITH(make_camera(c), Catch::Contains("RGB8"));
  c.aravis.pixel_format = "Coord3D_ABC32f";
  auto cam = make_camera(c);
  REQUIRE(cam);
  CHECK(cam->identity().address == "192.0.2.10");
  CHECK(cam->state() == CameraState::kClosed);
}

TEST_CASE("replay plays frames in name order, one per trigger, and loops") {
  TempDir dir("order");
  write_frames(dir, {"b", "a", "c"});
  auto cam = make_camera(replay_config(dir, true, 0.0));
  REQUIRE(cam->open().ok());
  REQUIRE(cam->start().ok());
  CHECK(cam->trigger_mode());

  // No trigger: the grab times out and says so.
  auto none = cam->grab(milliseconds(20));
  REQUIRE_FALSE(none.ok());
  CHECK(none.error().find("trigger") != std::string::npos);
  CHECK(cam->counters().timeouts == 1);

  const std::vector<std::string> expected = {"a", "b", "c", "a"};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    REQUIRE(cam->software_trigger().ok());
    auto frame = cam->grab(milliseconds(500));
    REQUIRE(frame.ok());
    auto file = read_frame((dir.path() / expected[i]).string());
    REQUIRE(file.ok());
    CHECK(frame->depth == file->depth);
    CHECK(frame->sequence == i);
  }
  CHECK(cam->counters().frames == 4);
}

TEST_CASE("replay once ends with an error, a set rate paces frames") {
  TempDir dir("rate");
  write_frames(dir, {"f0", "f1", "f2"});
  auto cam = make_camera(replay_config(dir, false, 50.0));
  REQUIRE(cam->open().ok());
  REQUIRE(cam->start().ok());
  CHECK_FALSE(cam->trigger_mode());
  CHECK_FALSE(cam->software_trigger().ok());  // free-running: no trigger
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < 3; ++i) REQUIRE(cam->grab(milliseconds(1000)).ok());
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  CHECK(elapsed_s >= 2.0 / 50.0 * 0.9);  // three frames at 50 Hz span two periods
  auto end = cam->grab(milliseconds(1000));
  REQUIRE_FALSE(end.ok());
  CHECK(end.error().find("end of recording") != std::string::npos);
  CHECK(cam->state() == CameraState::kStreaming);  // the end is not a fault
}

TEST_CASE("a bad frame file fails its grab naming the file, the next grab goes on") {
  TempDir dir("bad");
  write_frames(dir, {"a", "b", "c"});
  {
    std::ofstream junk(dir.path() / "b.depth.png", std::ios::binary | std::ios::trunc);
    junk << "not a png";
  }
  auto cam = make_camera(replay_config(dir, false, 0.0));
  REQUIRE(cam->open().ok());
  REQUIRE(cam->start().ok());
  REQUIRE(cam->software_trigger().ok());
  REQUIRE(cam->grab(milliseconds(200)).ok());
  REQUIRE(cam->software_trigger().ok());
  auto bad = cam->grab(milliseconds(200));
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.error().find((dir.path() / "b").string()) != std::string::npos);
  CHECK(cam->state() == CameraState::kStreaming);
  REQUIRE(cam->software_trigger().ok());
  auto c = cam->grab(milliseconds(200));
  REQUIRE(c.ok());
  CHECK(c->depth == read_frame((dir.path() / "c").string())->depth);
  CHECK(cam->counters().incomplete == 1);
  CHECK(cam->counters().frames == 2);
}

TEST_CASE("intrinsics override replaces the file's intrinsics and must match its size") {
  TempDir dir("override");
  write_frames(dir, {"a"}, 32, 24);
  CameraConfig c = replay_config(dir, true, 0.0);
  Intrinsics k;
  k.width = 32;
  k.height = 24;
  k.fx = k.fy = 100.0;
  k.cx = 15.0;
  k.cy = 11.0;
  c.intrinsics_override = k;
  auto cam = make_camera(c);
  REQUIRE(cam->open().ok());
  REQUIRE(cam->start().ok());
  REQUIRE(cam->software_trigger().ok());
  auto f = cam->grab(milliseconds(200));
  REQUIRE(f.ok());
  CHECK(f->intrinsics.fx == 100.0);
  CHECK(f->intrinsics.cx == 15.0);

  k.width = 64;
  c.intrinsics_override = k;
  auto cam2 = make_camera(c);
  REQUIRE(cam2->open().ok());
  REQUIRE(cam2->start().ok());
  REQUIRE(cam2->software_trigger().ok());
  auto bad = cam2->grab(milliseconds(200));
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.error().find("64x24") != std::string::npos);
}

TEST_CASE("backoff doubles from min to max and resets") {
  Backoff b(0.5, 3.0);
  CHECK(b.next_delay_s() == 0.5);
  CHECK(b.next_delay_s() == 1.0);
  CHECK(b.next_delay_s() == 2.0);
  CHECK(b.next_delay_s() == 3.0);
  CHECK(b.next_delay_s() == 3.0);
  b.reset();
  CHECK(b.next_delay_s() == 0.5);
}

TEST_CASE("supervisor reconnects a replay camera after its folder is removed and restored") {
  TempDir dir("reconnect");
  const auto frames_dir = dir.path() / "frames";
  const auto hidden_dir = dir.path() / "hidden";
  std::filesystem::create_directories(frames_dir);
  for (int i = 0; i < 2; ++i) {
    REQUIRE(write_frame((frames_dir / ("f" + std::to_string(i))).string(),
                        synthetic_frame(16, 12, static_cast<std::uint32_t>(i))).ok());
  }
  CameraConfig c = replay_config(dir, true, 200.0);
  c.replay.directory = frames_dir.string();
  CameraSupervisor sup(make_camera(c), c.reconnect_min_s, c.reconnect_max_s);
  CHECK_FALSE(sup.camera_ok());  // nothing opened before the first grab

  REQUIRE(sup.grab(milliseconds(500)).ok());
  CHECK(sup.camera_ok());
  CHECK(sup.state() == CameraState::kStreaming);

  std::filesystem::rename(frames_dir, hidden_dir);  // the "camera" goes away
  auto lost = sup.grab(milliseconds(200));
  REQUIRE_FALSE(lost.ok());
  CHECK(lost.error().find("gone") != std::string::npos);
  CHECK_FALSE(sup.camera_ok());
  CHECK(sup.counters().faults == 1);

  // While it is away, grabs fail without spinning and the camera stays down.
  for (int i = 0; i < 4; ++i) CHECK_FALSE(sup.grab(milliseconds(30)).ok());
  CHECK_FALSE(sup.camera_ok());
  CHECK(sup.counters().reconnects == 0);

  std::filesystem::rename(hidden_dir, frames_dir);  // and comes back
  bool back = false;
  for (int i = 0; i < 50 && !back; ++i) back = sup.grab(milliseconds(50)).ok();
  REQUIRE(back);
  CHECK(sup.camera_ok());
  CHECK(sup.counters().reconnects == 1);
  CHECK(sup.counters().faults == 1);
  CHECK(sup.counters().frames >= 2);
}
