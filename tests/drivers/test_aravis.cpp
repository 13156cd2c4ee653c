// The Aravis driver against Aravis's own fake GigE Vision camera (ArvGvFakeCamera), over real
// GVCP/GVSP on loopback, in a private network namespace. The fake camera's GenICam XML is the
// library's own with Coord3D_C16, Coord3D_ABC32f and the Scan3d features added; its fill
// callback serves synthetic frames that are also written to a replay folder, and every frame
// through the driver must carry the same depth as the same frame through replay.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <mutex>
#include <thread>

#include <arv.h>
#include <catch2/catch.hpp>
#include <sys/wait.h>

#include "palletd/config/config.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/frames/frame_io.hpp"

#include "aravis_fake.hpp"
#include "drivers_test_util.hpp"
#include "netns.hpp"

using namespace palletd;
using palletd::test::synthetic_frame;
using palletd::test::TempDir;
using namespace palletd::test;
using std::chrono::milliseconds;

TEST_CASE("aravis Coord3D_C16 frames arrive byte-identical to replay, one per software trigger") {
  SKIP_WITHOUT_NETNS();
  Fixture fx(3);
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  auto cam = make_camera(aravis_config("Coord3D_C16", true));
  Status opened = cam->open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  CHECK(cam->identity().serial == "PD3D01");
  CHECK(cam->identity().address == "127.0.0.1");
  CHECK(cam->trigger_mode());
  REQUIRE(cam->start().ok());
  for (std::size_t i = 0; i < fx.replayed.size(); ++i) {
    REQUIRE(cam->software_trigger().ok());
    auto frame = cam->grab(milliseconds(3000));
    INFO(frame.error());
    REQUIRE(frame.ok());
    const Frame& want = fx.replayed[i];
    CHECK(frame->depth == want.depth);
    CHECK(frame->depth_scale_m == want.depth_scale_m);
    CHECK(frame->intrinsics.width == want.intrinsics.width);
    CHECK(frame->intrinsics.fx == want.intrinsics.fx);
    CHECK(frame->intrinsics.cx == want.intrinsics.cx);
    CHECK(frame->intrinsics.cy == want.intrinsics.cy);
    CHECK(frame->camera_id == "Fake-PD3D01");
  }
  CHECK(cam->counters().frames == fx.replayed.size());
  CHECK(cam->counters().incomplete == 0);
  cam->close();
}

TEST_CASE("aravis: a frame left waiting from an earlier trigger is not the next trigger's frame") {
  // The PLC triggers, the grab gives up, the frame comes late and waits in the stream; the next
  // trigger's frame must show the pallet as it is then, not the waiting one.
  SKIP_WITHOUT_NETNS();
  Fixture fx(3);
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  auto cam = make_camera(aravis_config("Coord3D_C16", true));
  REQUIRE(cam->open().ok());
  REQUIRE(cam->start().ok());
  REQUIRE(cam->software_trigger().ok());  // frame 0: never grabbed
  std::this_thread::sleep_for(milliseconds(500));
  REQUIRE(cam->software_trigger().ok());  // frame 1
  auto frame = cam->grab(milliseconds(3000));
  INFO(frame.error());
  REQUIRE(frame.ok());
  CHECK(frame->depth == fx.replayed[1].depth);
  CHECK_FALSE(frame->depth == fx.replayed[0].depth);
  CHECK_FALSE(cam->grab(milliseconds(300)).ok());  // nothing else waits
  cam->close();
}

TEST_CASE("aravis Coord3D_ABC32f gives Z quantised to 0.1 mm, the same depth as replay") {
  SKIP_WITHOUT_NETNS();
  Fixture fx(2);
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  auto cam = make_camera(aravis_config("Coord3D_ABC32f", true));
  Status opened = cam->open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  REQUIRE(cam->start().ok());
  for (const Frame& want : fx.replayed) {
    REQUIRE(cam->software_trigger().ok());
    auto frame = cam->grab(milliseconds(3000));
    INFO(frame.error());
    REQUIRE(frame.ok());
    CHECK(frame->depth_scale_m == 1e-4);
    REQUIRE(frame->depth.size() == want.depth.size());
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < want.depth.size(); ++i) {
      // Same metres: millimetres x 10 = tenths of a millimetre.
      if (frame->depth[i] != static_cast<std::uint16_t>(want.depth[i] * 10)) ++mismatches;
    }
    CHECK(mismatches == 0);
  }
}

TEST_CASE("aravis Mono16 free-running uses the configured scale") {
  SKIP_WITHOUT_NETNS();
  Fixture fx(2);
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  CameraConfig c = aravis_config("Mono16", false);
  c.aravis.mono16_scale_m = 0.001;
  auto cam = make_camera(c);
  Status opened = cam->open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  CHECK_FALSE(cam->trigger_mode());
  REQUIRE(cam->start().ok());
  for (int k = 0; k < 3; ++k) {
    auto frame = cam->grab(milliseconds(3000));
    INFO(frame.error());
    REQUIRE(frame.ok());
    CHECK(frame->depth_scale_m == 0.001);
    // Free-running: each frame must be one of the served frames, byte for byte.
    const bool known = frame->depth == fx.replayed[0].depth || frame->depth == fx.replayed[1].depth;
    CHECK(known);
  }
}

TEST_CASE("aravis refuses a camera whose serial differs from the configured one") {
  SKIP_WITHOUT_NETNS();
  Fixture fx(1);
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  CameraConfig c = aravis_config("Coord3D_C16", true);
  c.aravis.serial = "OTHER42";
  auto cam = make_camera(c);
  Status opened = cam->open();
  REQUIRE_FALSE(opened.ok());
  CHECK(opened.error().find("OTHER42") != std::string::npos);
  CHECK(opened.error().find("PD3D01") != std::string::npos);
  CHECK(cam->state() == CameraState::kClosed);
}

TEST_CASE("aravis camera stopped and restarted mid-stream: the supervisor reconnects") {
  SKIP_WITHOUT_NETNS();
  Fixture fx(2);
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  CameraConfig c = aravis_config("Coord3D_C16", false);
  CameraSupervisor sup(make_camera(c), c.reconnect_min_s, c.reconnect_max_s);
  auto first = sup.grab(milliseconds(3000));
  INFO(first.error());
  REQUIRE(first.ok());
  CHECK(sup.camera_ok());

  fake.reset();  // power off
  bool faulted = false;
  for (int i = 0; i < 40 && !faulted; ++i) {
    auto f = sup.grab(milliseconds(250));
    faulted = !f.ok() && sup.state() != CameraState::kStreaming;
  }
  REQUIRE(faulted);
  CHECK_FALSE(sup.camera_ok());
  CHECK(sup.counters().faults == 1);

  fake = start_fake(fx.xml, fx.source, fx.replayed[0]);  // power on
  bool back = false;
  for (int i = 0; i < 60 && !back; ++i) back = sup.grab(milliseconds(250)).ok();
  REQUIRE(back);
  CHECK(sup.camera_ok());
  CHECK(sup.counters().reconnects == 1);
  auto after = sup.grab(milliseconds(3000));
  REQUIRE(after.ok());
  const bool known = after->depth == fx.replayed[0].depth || after->depth == fx.replayed[1].depth;
  CHECK(known);
  sup.shutdown();
}

namespace {

/// Runs palletctl (built beside the tests); returns its exit status and stdout.
int run_palletctl(const std::string& args, const TempDir& dir, std::string& out) {
  const std::string log = (dir.path() / "palletctl.out").string();
  const std::string cmd = std::string(PALLETD_BINARY_DIR) + "/src/palletctl/palletctl " + args + " > " + log + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST_CASE("palletctl grab writes the same frames through replay and through aravis") {
  SKIP_WITHOUT_NETNS();
  Fixture fx(2);
  std::string out;

  // Replay: the frames folder in, two frames out, byte-identical.
  const auto replay_yaml = fx.dir.path() / "replay.yaml";
  std::ofstream(replay_yaml) << "camera:\n  driver: replay\n  replay:\n    directory: "
                             << (fx.dir.path() / "frames").string() << "\n    loop: false\n";
  const auto replay_out = fx.dir.path() / "grab-replay";
  const int rc = run_palletctl("grab --config " + replay_yaml.string() + " -n 2 --out " + replay_out.string(),
                               fx.dir, out);
  INFO(out);
  REQUIRE(rc == 0);
  for (int i = 0; i < 2; ++i) {
    auto f = read_frame((replay_out / ("frame-00000" + std::to_string(i))).string());
    REQUIRE(f.ok());
    CHECK(f->depth == fx.replayed[static_cast<std::size_t>(i)].depth);
  }

  // Aravis: the fake camera serving the same frames.
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  const auto aravis_yaml = fx.dir.path() / "aravis.yaml";
  std::ofstream(aravis_yaml) << "camera:\n  driver: aravis\n  aravis:\n    address: 127.0.0.1\n"
                             << "    pixel_format: Coord3D_C16\n    packet_size: 1400\n";
  const auto aravis_out = fx.dir.path() / "grab-aravis";
  const int rc2 = run_palletctl("grab --config " + aravis_yaml.string() + " -n 2 --out " + aravis_out.string(),
                                fx.dir, out);
  INFO(out);
  REQUIRE(rc2 == 0);
  CHECK(out.find("PD3D01") != std::string::npos);
  for (int i = 0; i < 2; ++i) {
    auto f = read_frame((aravis_out / ("frame-00000" + std::to_string(i))).string());
    REQUIRE(f.ok());
    CHECK(f->depth == fx.replayed[static_cast<std::size_t>(i)].depth);
    CHECK(f->depth_scale_m == fx.replayed[static_cast<std::size_t>(i)].depth_scale_m);
  }

  // A camera that is not there: a clear error and a non-zero exit.
  fake.reset();
  const int rc3 = run_palletctl("grab --config " + aravis_yaml.string() + " -n 1 --out " + aravis_out.string(),
                                fx.dir, out);
  CHECK(rc3 != 0);
  CHECK(out.find("127.0.0.1") != std::string::npos);
}

TEST_CASE("palletctl record writes a replayable ring from the configured camera") {
  Fixture fx(3);
  std::string out;
  const auto yaml = fx.dir.path() / "record.yaml";
  std::ofstream(yaml) << "camera:\n  driver: replay\n  replay:\n    directory: "
                      << (fx.dir.path() / "frames").string() << "\n    loop: true\n    rate_hz: 100\n";
  const auto ring = fx.dir.path() / "ring";
  const int rc = run_palletctl("record --config " + yaml.string() + " -n 5 --out " + ring.string(), fx.dir, out);
  INFO(out);
  REQUIRE(rc == 0);
  CHECK(out.find("recorded 5 frame(s)") != std::string::npos);
  auto stems = list_frame_stems(ring.string());
  REQUIRE(stems.ok());
  REQUIRE(stems->size() == 5);
  for (std::size_t i = 0; i < stems->size(); ++i) {
    auto f = read_frame((*stems)[i]);
    REQUIRE(f.ok());
    CHECK(f->depth == fx.replayed[i % fx.replayed.size()].depth);  // looped in order
  }
}
