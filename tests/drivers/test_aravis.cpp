// The Aravis driver against Aravis's own fake GigE Vision camera (ArvGvFakeCamera), over real
// GVCP/GVSP on loopback, in a private network namespace. The fake camera's GenICam XML is the
// library's own with Coord3D_C16, Coord3D_ABC32f and the Scan3d features added; its fill
// callback serves synthetic frames that are also written to a replay folder, and every frame
// through the driver must carry the same depth as the same frame through replay.
#include <catch2/catch.hpp>

#include <arv.h>

#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <cstring>
#include <fstream>
#include <mutex>
#include <thread>

#include "drivers_test_util.hpp"
#include "netns.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/config/config.hpp"
#include "palletd/frames/frame_io.hpp"

using namespace palletd;
using palletd::test::synthetic_frame;
using palletd::test::TempDir;
using std::chrono::milliseconds;

namespace {

constexpr std::uint32_t kScaleAddr = 0x8000;   // doubles, big-endian
constexpr std::uint32_t kOffsetAddr = 0x8008;
constexpr std::uint32_t kFocalAddr = 0x8010;
constexpr std::uint32_t kPpuAddr = 0x8018;
constexpr std::uint32_t kPpvAddr = 0x8020;
constexpr std::uint32_t kInvalidAddr = 0x8028;

std::string float_feature(const std::string& name, std::uint32_t address) {
  char addr[16];
  std::snprintf(addr, sizeof addr, "0x%x", address);
  return "\t<Float Name=\"" + name + "\" NameSpace=\"Standard\">\n\t\t<pValue>" + name +
         "Reg</pValue>\n\t</Float>\n\t<FloatReg Name=\"" + name +
         "Reg\" NameSpace=\"Custom\">\n\t\t<Address>" + addr +
         "</Address>\n\t\t<Length>8</Length>\n\t\t<AccessMode>RW</AccessMode>\n"
         "\t\t<pPort>Device</pPort>\n\t\t<Endianess>BigEndian</Endianess>\n\t</FloatReg>\n";
}

/// The fake camera's own GenICam XML plus the 3D pixel formats and Scan3d features.
std::string write_genicam_xml(const TempDir& dir) {
  ArvFakeCamera* probe = arv_fake_camera_new("PROBE");
  size_t size = 0;
  const char* text = arv_fake_camera_get_genicam_xml(probe, &size);
  std::string xml(text, size);
  g_object_unref(probe);

  const std::string anchor = "<pValue>PixelFormatRegister</pValue>";
  const auto at = xml.find(anchor);
  REQUIRE(at != std::string::npos);
  xml.insert(at, "<EnumEntry Name=\"Coord3D_C16\" NameSpace=\"Standard\"><Value>" +
                     std::to_string(ARV_PIXEL_FORMAT_COORD3D_C_16) + "</Value></EnumEntry>\n\t\t" +
                     "<EnumEntry Name=\"Coord3D_ABC32f\" NameSpace=\"Standard\"><Value>" +
                     std::to_string(ARV_PIXEL_FORMAT_COORD3D_ABC_32F) + "</Value></EnumEntry>\n\t\t");
  std::string features = float_feature("Scan3dCoordinateScale", kScaleAddr) +
                         float_feature("Scan3dCoordinateOffset", kOffsetAddr) +
                         float_feature("Scan3dFocalLength", kFocalAddr) +
                         float_feature("Scan3dPrincipalPointU", kPpuAddr) +
                         float_feature("Scan3dPrincipalPointV", kPpvAddr) +
                         float_feature("Scan3dInvalidDataValue", kInvalidAddr);
  const auto port = xml.find("<Port Name=\"Device\"");
  REQUIRE(port != std::string::npos);
  xml.insert(port, features);
  const std::string path = (dir.path() / "fake-3d.xml").string();
  std::ofstream(path) << xml;
  return path;
}

void write_double(ArvFakeCamera* camera, std::uint32_t address, double value) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof bits);
  bits = __builtin_bswap64(bits);
  REQUIRE(arv_fake_camera_write_memory(camera, address, sizeof bits, &bits));
}

/// What the fake camera's fill callback serves: the frames in turn.
struct FakeSource {
  std::mutex mutex;
  std::vector<Frame> frames;
  std::size_t next = 0;
  std::size_t served = 0;
};

void fill(ArvBuffer* buffer, void* data, guint32 /*exposure_us*/, guint32 /*gain*/, ArvPixelFormat format) {
  auto* source = static_cast<FakeSource*>(data);
  std::lock_guard<std::mutex> lock(source->mutex);
  if (source->frames.empty()) return;
  const Frame& f = source->frames[source->next++ % source->frames.size()];
  ++source->served;
  // The fake camera's buffer reports size 0 to the callback; it holds PayloadSize bytes,
  // which is Width x Height x bytes per pixel (the registers were set to the frame's size).
  size_t size = 0;
  auto* out = static_cast<unsigned char*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
  if (arv_buffer_get_image_width(buffer) != f.intrinsics.width ||
      arv_buffer_get_image_height(buffer) != f.intrinsics.height) {
    return;
  }
  const std::size_t n = f.pixel_count();
  if (format == ARV_PIXEL_FORMAT_COORD3D_ABC_32F) {
    for (std::size_t i = 0; i < n; ++i) {
      const int u = static_cast<int>(i % static_cast<std::size_t>(f.intrinsics.width));
      const int v = static_cast<int>(i / static_cast<std::size_t>(f.intrinsics.width));
      const float z_mm = static_cast<float>(f.depth[i]);  // frames are in millimetres
      const float xyz[3] = {static_cast<float>((u - f.intrinsics.cx) * z_mm / f.intrinsics.fx),
                            static_cast<float>((v - f.intrinsics.cy) * z_mm / f.intrinsics.fy),
                            f.depth[i] == 0 ? std::nanf("") : z_mm};
      std::memcpy(out + i * 12, xyz, sizeof xyz);
    }
  } else {
    std::memcpy(out, f.depth.data(), n * 2);
  }
}

using FakeGvPtr = std::unique_ptr<ArvGvFakeCamera, void (*)(ArvGvFakeCamera*)>;

FakeGvPtr start_fake(const std::string& xml, FakeSource& source, const Frame& shape) {
  FakeGvPtr fake(arv_gv_fake_camera_new_full("127.0.0.1", "PD3D01", xml.c_str()),
                 [](ArvGvFakeCamera* p) { g_object_unref(p); });
  REQUIRE(fake);
  REQUIRE(arv_gv_fake_camera_is_running(fake.get()));
  ArvFakeCamera* cam = arv_gv_fake_camera_get_fake_camera(fake.get());
  arv_fake_camera_write_register(cam, ARV_FAKE_CAMERA_REGISTER_WIDTH,
                                 static_cast<guint32>(shape.intrinsics.width));
  arv_fake_camera_write_register(cam, ARV_FAKE_CAMERA_REGISTER_HEIGHT,
                                 static_cast<guint32>(shape.intrinsics.height));
  write_double(cam, kScaleAddr, 1.0);  // millimetres per unit, as the frames
  write_double(cam, kOffsetAddr, 0.0);
  write_double(cam, kFocalAddr, shape.intrinsics.fx);
  write_double(cam, kPpuAddr, shape.intrinsics.cx);
  write_double(cam, kPpvAddr, shape.intrinsics.cy);
  write_double(cam, kInvalidAddr, 0.0);
  arv_fake_camera_set_fill_pattern(cam, fill, &source);
  return fake;
}

/// Frames, written to a replay folder and read back through the replay driver.
struct Fixture {
  TempDir dir{"aravis"};
  std::string xml;
  FakeSource source;
  std::vector<Frame> replayed;

  explicit Fixture(int count) {
    xml = write_genicam_xml(dir);
    const auto frames_dir = dir.path() / "frames";
    std::filesystem::create_directories(frames_dir);
    for (int i = 0; i < count; ++i) {
      REQUIRE(write_frame((frames_dir / ("f" + std::to_string(i))).string(),
                          synthetic_frame(96, 72, static_cast<std::uint32_t>(20 + i))).ok());
    }
    CameraConfig rc;
    rc.driver = "replay";
    rc.replay.directory = frames_dir.string();
    rc.replay.loop = false;
    auto replay = make_camera(rc);
    REQUIRE(replay->open().ok());
    REQUIRE(replay->start().ok());
    for (int i = 0; i < count; ++i) {
      REQUIRE(replay->software_trigger().ok());
      auto f = replay->grab(milliseconds(500));
      REQUIRE(f.ok());
      replayed.push_back(f.value());
    }
    source.frames = replayed;
  }
};

CameraConfig aravis_config(const std::string& format, bool trigger) {
  CameraConfig c;
  c.driver = "aravis";
  c.aravis.address = "127.0.0.1";
  c.aravis.pixel_format = format;
  c.aravis.software_trigger = trigger;
  c.aravis.packet_size = 1400;
  c.aravis.buffer_count = 4;
  c.reconnect_min_s = 0.1;
  c.reconnect_max_s = 0.4;
  return c;
}

#define SKIP_WITHOUT_NETNS()                                                        \
  do {                                                                              \
    const std::string why = palletd::test::enter_private_netns();                   \
    if (!why.empty()) {                                                             \
      WARN("skipped: no private network namespace for the fake camera: " << why);   \
      SUCCEED("skipped: " << why);                                                  \
      return;                                                                       \
    }                                                                               \
  } while (false)

}  // namespace

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
