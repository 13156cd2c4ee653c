// The OpenNI2 driver through the real OpenNI2 runtime, against the palletd test device
// (openni2_test_device.cpp, loaded from the private runtime folder PALLETD_ONI_RUNTIME) and
// against .oni files recorded from it with openni::Recorder.
#include <catch2/catch.hpp>

#include <OpenNI.h>
#include <sys/wait.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "detection_compare.hpp"
#include "drivers_test_util.hpp"
#include "openni2/openni2_camera.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/config/config.hpp"
#include "palletd/frames/frame_io.hpp"

using namespace palletd;
using palletd::test::TempDir;
using std::chrono::milliseconds;
namespace fs = std::filesystem;

namespace {

const std::string kData = PALLETD_TEST_DATA_DIR;

const std::string kXtion = kData + "/22_block_600x400_xtion";           // 640x480, 1 mm, 8-bit IR
const std::string kBlaze = kData + "/20_interlock_400x300_blaze101";    // 640x480, 0.2 mm, 16-bit IR
const std::string kHelios = kData + "/21_pinwheel_315x232_corner_helios2";  // 640x480, 0.25 mm, 16-bit IR

void copy_frame(const std::string& stem, const fs::path& dir, const std::string& name) {
  for (const char* ext : {".depth.png", ".json", ".intensity.png"}) {
    if (fs::exists(stem + ext)) fs::copy_file(stem + ext, dir / (name + ext), fs::copy_options::overwrite_existing);
  }
}

/// A frame folder for the test device and the frames it serves, in name order.
struct Source {
  TempDir dir{"openni2"};
  fs::path frames;
  std::vector<Frame> served;

  /// kind 1: the xtion frame and two synthetic ones (1 mm, 8-bit IR).
  /// kind 2: blaze and helios2 (0.2 / 0.25 mm, 16-bit IR).
  explicit Source(int kind) : frames(dir.path() / "frames") {
    fs::create_directories(frames);
    if (kind == 1) {
      copy_frame(kXtion, frames, "a_xtion");
      for (std::uint32_t seed : {7u, 8u}) {
        Frame f = test::synthetic_frame(640, 480, seed);
        f.intensity.assign(f.depth.size(), 0);
        for (std::size_t i = 0; i < f.intensity.size(); ++i) f.intensity[i] = static_cast<std::uint16_t>((i * seed) % 256);
        f.intensity_bits = 8;
        REQUIRE(write_frame((frames / ("b_synth" + std::to_string(seed))).string(), f).ok());
      }
    } else {
      copy_frame(kBlaze, frames, "a_blaze");
      copy_frame(kHelios, frames, "b_helios");
    }
    auto stems = list_frame_stems(frames.string());
    REQUIRE(stems.ok());
    for (const auto& s : *stems) {
      auto f = read_frame(s);
      REQUIRE(f.ok());
      served.push_back(std::move(*f));
    }
  }
  [[nodiscard]] std::string uri() const { return "palletd-test://" + frames.string(); }
};

/// The source frame whose depth, converted to `unit_m`, equals `f` exactly; -1 if none.
int match_source(const Frame& f, const std::vector<Frame>& served) {
  for (std::size_t k = 0; k < served.size(); ++k) {
    const Frame& s = served[k];
    if (s.depth.size() != f.depth.size()) continue;
    bool same = true;
    for (std::size_t i = 0; i < s.depth.size() && same; ++i) {
      const double want = std::round(s.depth[i] * s.depth_scale_m / f.depth_scale_m);
      same = static_cast<double>(f.depth[i]) == want;
    }
    if (same) return static_cast<int>(k);
  }
  return -1;
}

/// Grabs `n` frames and checks each against the source frames (exact depth and, with `with_ir`,
/// the IR image of that same source frame on every frame; order cyclic when nothing was
/// dropped). The sources differ from frame to frame, so an IR image one or two frames off its
/// depth frame fails the check. Returns the matched source indices.
std::vector<int> grab_and_match(OpenNI2Camera& cam, const Source& src, int n, double unit_m, bool with_ir) {
  std::vector<int> idx;
  for (int i = 0; i < n; ++i) {
    auto f = cam.grab(milliseconds(3000));
    INFO(cam.last_error());
    REQUIRE(f.ok());
    CHECK(f->depth_scale_m == unit_m);
    const int k = match_source(*f, src.served);
    REQUIRE(k >= 0);
    idx.push_back(k);
    if (with_ir) {
      REQUIRE(f->has_intensity());
      CHECK(f->intensity_bits == src.served[static_cast<std::size_t>(k)].intensity_bits);
      CHECK(test::same_pixels(f->intensity, src.served[static_cast<std::size_t>(k)].intensity));
    }
    CHECK(f->sequence + 1 == cam.counters().frames);  // the driver's own counter, from 0
    CHECK(f->timestamp_ns > 0);
  }
  if (with_ir) CHECK(cam.frames_without_ir() == 0);
  if (cam.counters().drops == 0) {
    for (std::size_t i = 1; i < idx.size(); ++i) {
      CHECK(idx[i] == (idx[i - 1] + 1) % static_cast<int>(src.served.size()));
    }
  }
  return idx;
}

/// Grabs until the frame of source `k` comes (at most 40 grabs); nullopt if it does not. The
/// driver delivers the newest frame, so a consumer slower than the frame rate skips frames, and
/// with a steady pace it could skip source k every time (2 or 3 sources in turn): the pause
/// between grabs varies.
std::optional<Frame> grab_source(Camera& cam, const Source& src, int k) {
  for (int i = 0; i < 40; ++i) {
    auto f = cam.grab(milliseconds(3000));
    INFO(cam.last_error());
    REQUIRE(f.ok());
    if (match_source(*f, src.served) == k) return std::move(*f);
    std::this_thread::sleep_for(milliseconds(11 * (i % 4)));
  }
  return std::nullopt;
}

/// The test device's pause property (openni2_test_device.cpp).
constexpr int kPauseProperty = 0x70A11E70;

/// Records at least `min_frames` depth and IR frames of the test device into `path` with
/// openni::Recorder and returns the number of depth frames. The recorder rebases each stream's
/// timestamps to that stream's first recorded frame, so the recording has to start (and end) with
/// a whole depth+IR pair for the two streams' timestamps to agree: the device is paused while the
/// recorder starts and before it stops (a pause returns once the instant under way went out).
int record_oni(const std::string& uri, const std::string& path, int min_frames) {
  REQUIRE(openni::OpenNI::initialize() == openni::STATUS_OK);
  int recorded = 0;
  {
    openni::Device device;
    REQUIRE(device.open(uri.c_str()) == openni::STATUS_OK);
    openni::VideoStream depth, ir;
    REQUIRE(depth.create(device, openni::SENSOR_DEPTH) == openni::STATUS_OK);
    REQUIRE(ir.create(device, openni::SENSOR_IR) == openni::STATUS_OK);
    REQUIRE(device.setProperty(kPauseProperty, 1) == openni::STATUS_OK);
    openni::Recorder recorder;
    REQUIRE(recorder.create(path.c_str()) == openni::STATUS_OK);
    REQUIRE(recorder.attach(depth, false) == openni::STATUS_OK);
    REQUIRE(recorder.attach(ir, false) == openni::STATUS_OK);
    REQUIRE(depth.start() == openni::STATUS_OK);
    REQUIRE(ir.start() == openni::STATUS_OK);
    REQUIRE(recorder.start() == openni::STATUS_OK);
    // The recorder starts on its own thread; give it time before the first frame goes out.
    std::this_thread::sleep_for(milliseconds(100 * PALLETD_TEST_TIME_SCALE));
    REQUIRE(device.setProperty(kPauseProperty, 0) == openni::STATUS_OK);
    openni::VideoStream* streams[] = {&depth};
    int last_index = 0;
    while (recorded < min_frames) {
      int ready = -1;
      REQUIRE(openni::OpenNI::waitForAnyStream(streams, 1, &ready, 2000) == openni::STATUS_OK);
      openni::VideoFrameRef ref;
      REQUIRE(depth.readFrame(&ref) == openni::STATUS_OK);
      REQUIRE(ref.isValid());
      recorded += ref.getFrameIndex() - (last_index == 0 ? ref.getFrameIndex() - 1 : last_index);
      last_index = ref.getFrameIndex();
    }
    REQUIRE(device.setProperty(kPauseProperty, 1) == openni::STATUS_OK);
    recorder.stop();
    recorder.destroy();
    ir.stop();
    depth.stop();
  }
  openni::OpenNI::shutdown();
  return recorded;
}

OpenNI2Options device_options(const std::string& uri, double unit_m = 0.001) {
  OpenNI2Options o;
  o.uri = uri;
  o.depth_unit_m = unit_m;
  return o;
}

}  // namespace

TEST_CASE("openni2: the test device through the runtime gives the source frames in mm - with IR") {
  Source src(1);
  OpenNI2Camera cam(device_options(src.uri()));
  REQUIRE(cam.state() == CameraState::kClosed);
  Status opened = cam.open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  const CameraIdentity id = cam.identity();
  CHECK(id.driver == "openni2");
  CHECK(id.vendor == "palletd");
  CHECK(id.serial == "PDONI01");
  CHECK(id.address == src.uri());
  REQUIRE(cam.start().ok());
  const auto idx = grab_and_match(cam, src, 7, 0.001, true);
  // The xtion frame (the one in mm) arrives with its own depth values, unchanged.
  auto f = cam.grab(milliseconds(3000));
  REQUIRE(f.ok());
  const int k = match_source(*f, src.served);
  REQUIRE(k >= 0);
  CHECK(test::same_pixels(f->depth, src.served[static_cast<std::size_t>(k)].depth));
  // Intrinsics from the device's field of view: the source's fx/fy (through a float FOV), the
  // principal point at the centre of the pixel grid.
  const Intrinsics& want = src.served[0].intrinsics;
  CHECK(f->intrinsics.width == 640);
  CHECK(f->intrinsics.fx == Approx(want.fx).margin(2e-3));
  CHECK(f->intrinsics.fy == Approx(want.fy).margin(2e-3));
  CHECK(f->intrinsics.cx == 319.5);
  CHECK(f->intrinsics.cy == 239.5);
  CHECK(f->camera_id == id.id());
  CHECK(cam.counters().frames == 8);
  REQUIRE(cam.stop().ok());
  cam.close();
  CHECK(cam.state() == CameraState::kClosed);
  (void)idx;
}

TEST_CASE("openni2: 100 um mode - first device - configured intrinsics") {
  Source src(2);
  ::setenv("PALLETD_OPENNI2_TEST_FRAMES", src.frames.string().c_str(), 1);
  OpenNI2Options o = device_options("", 0.0001);  // the first device: the one announced
  Intrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 500.0;
  k.cx = 320.0;
  k.cy = 240.0;
  o.intrinsics_override = k;
  OpenNI2Camera cam(o);
  Status opened = cam.open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  CHECK(cam.identity().address == src.uri());
  REQUIRE(cam.start().ok());
  grab_and_match(cam, src, 4, 0.0001, true);
  auto f = cam.grab(milliseconds(3000));
  REQUIRE(f.ok());
  CHECK(f->intrinsics.fx == 500.0);
  CHECK(f->intrinsics.cx == 320.0);
  // The blaze frame (0.2 mm units) arrives as exactly twice its values in 100 um units.
  const int m = match_source(*f, src.served);
  REQUIRE(m >= 0);
  const Frame& s = src.served[static_cast<std::size_t>(m)];
  if (s.depth_scale_m == 0.0002) {
    bool doubled = true;
    for (std::size_t i = 0; i < s.depth.size(); ++i) doubled = doubled && f->depth[i] == 2 * s.depth[i];
    CHECK(doubled);
  }
  cam.close();
  ::unsetenv("PALLETD_OPENNI2_TEST_FRAMES");
}

TEST_CASE("openni2: errors are values naming what failed") {
  Source src(1);
  {
    OpenNI2Camera cam(device_options("palletd-test:///no/such/folder"));
    Status st = cam.open();
    CHECK_FALSE(st.ok());
    CHECK(st.error().find("/no/such/folder") != std::string::npos);
    CHECK(cam.state() == CameraState::kClosed);
    CHECK_FALSE(cam.grab(milliseconds(10)).ok());
  }
  {
    OpenNI2Camera cam(device_options("/no/such/recording.oni"));
    Status st = cam.open();
    CHECK_FALSE(st.ok());
    CHECK(st.error().find("/no/such/recording.oni") != std::string::npos);
  }
  {
    OpenNI2Options o = device_options(src.uri());
    o.width = 1280;
    o.height = 1024;
    OpenNI2Camera cam(o);
    Status st = cam.open();
    CHECK_FALSE(st.ok());
    INFO(st.error());
    CHECK(st.error().find("1280x1024@30 1mm") != std::string::npos);
    CHECK(st.error().find("640x480@30 100um") != std::string::npos);  // what the device offers
  }
  {
    CameraConfig config;
    config.driver = "openni2";
    config.openni2.depth_unit_m = 0.0005;
    CHECK_THROWS_AS(make_camera(config), std::invalid_argument);
    config.openni2.depth_unit_m = 0.001;
    config.openni2.uri = src.uri();
    auto cam = make_camera(config);
    REQUIRE(cam);
    CHECK(cam->identity().driver == "openni2");
    REQUIRE(cam->open().ok());
    REQUIRE(cam->start().ok());
    CHECK(cam->grab(milliseconds(3000)).ok());
  }
}

TEST_CASE("openni2: frames recorded to .oni with openni::Recorder play back through the driver") {
  Source src(1);
  const std::string oni = (src.dir.path() / "rec.oni").string();
  const int recorded = record_oni(src.uri(), oni, 7);
  REQUIRE(recorded >= 7);

  // Once: every frame of the file, then the end of the recording.
  OpenNI2Options once = device_options(oni);
  once.loop = false;
  OpenNI2Camera cam(once);
  Status opened = cam.open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  const int in_file = cam.recording_frame_count();
  CHECK(in_file >= recorded);
  CHECK(cam.identity().serial == "rec");
  REQUIRE(cam.start().ok());
  // Every depth frame of the file has its IR partner in the file (record_oni), and each one
  // arrives with it: the IR image of the same source frame.
  std::vector<Frame> pass;
  std::uint64_t drops_before_first = 0;  // file frames skipped before the first one delivered
  for (int i = 0; i < in_file + 1; ++i) {
    auto f = cam.grab(milliseconds(3000));
    if (!f.ok()) {
      INFO(f.error());
      CHECK(f.error().find("end of recording") != std::string::npos);
      break;
    }
    if (pass.empty()) drops_before_first = cam.counters().drops;
    const int k = match_source(*f, src.served);
    REQUIRE(k >= 0);
    CHECK(f->depth_scale_m == 0.001);
    INFO("frame " << i << " of the recording");
    REQUIRE(f->has_intensity());
    CHECK(f->intensity_bits == 8);
    CHECK(test::same_pixels(f->intensity, src.served[static_cast<std::size_t>(k)].intensity));
    CHECK(f->intrinsics.fx == Approx(src.served[0].intrinsics.fx).margin(2e-3));
    pass.push_back(std::move(*f));
  }
  CHECK(static_cast<int>(pass.size() + cam.counters().drops) == in_file);
  CHECK(cam.frames_without_ir() == 0);
  CHECK(cam.state() == CameraState::kStreaming);  // the end of a recording is no fault
  cam.close();

  // Looping: the file is reopened at its end and plays from its first frame again.
  OpenNI2Camera loop(device_options(oni));
  REQUIRE(loop.open().ok());
  REQUIRE(loop.start().ok());
  std::vector<Frame> first;
  bool rewound = false;
  std::uint64_t drops_in_first_pass = 0;
  for (int i = 0; i < 3 * in_file && !rewound; ++i) {
    const std::uint64_t drops_before = loop.counters().drops;
    auto f = loop.grab(milliseconds(3000));
    INFO(loop.last_error());
    REQUIRE(f.ok());
    const int k = match_source(*f, src.served);
    REQUIRE(k >= 0);
    REQUIRE(f->has_intensity());
    CHECK(test::same_pixels(f->intensity, src.served[static_cast<std::size_t>(k)].intensity));
    if (loop.rewinds() == 1) {
      rewound = true;
      drops_in_first_pass = drops_before;
      // The file's first frame again, unless a slow grab skipped it (then counted as a drop).
      if (drops_before_first == 0 && loop.counters().drops == drops_before) {
        CHECK(test::same_pixels(f->depth, pass.front().depth));
        CHECK(test::same_pixels(f->intensity, pass.front().intensity));
      }
    } else {
      first.push_back(std::move(*f));
    }
  }
  CHECK(rewound);
  CHECK(static_cast<int>(first.size() + drops_in_first_pass) == in_file);
  CHECK(loop.frames_without_ir() == 0);
  CHECK(loop.counters().faults == 0);
}

TEST_CASE("openni2: a frame through the device and through .oni gives the same detection as through replay") {
  Source src(1);
  const auto formats = test::recipe_formats(kXtion);
  DetectionParams params;
  auto replayed = read_frame(kXtion);
  REQUIRE(replayed.ok());
  const Detection want = detect(*replayed, formats, params);
  // The seams in the intensity image take part in the layout choice and the refinement: the frame
  // has to come with its own IR image.
  auto want_for = [&](const Frame& f) {
    REQUIRE(f.has_intensity());
    CHECK(test::same_pixels(f.intensity, replayed->intensity));
    return want;
  };

  auto xtion_from = [&](Camera& cam) {
    std::optional<Frame> f = grab_source(cam, src, 0);
    INFO("the xtion frame never came");
    REQUIRE(f.has_value());
    return std::move(*f);
  };

  // Device, 1 mm: the depth values are the replayed ones exactly; the intrinsics differ only by
  // the float field of view (< 1e-3 px), so the poses agree to 0.1 mm / 0.01 deg.
  OpenNI2Camera cam(device_options(src.uri()));
  REQUIRE(cam.open().ok());
  REQUIRE(cam.start().ok());
  Frame live = xtion_from(cam);
  CHECK(test::same_pixels(live.depth, replayed->depth));
  live.T_base_camera = replayed->T_base_camera;  // calibration is the cell's, not the camera's
  test::require_same_detection(detect(live, formats, params), want_for(live), 1e-4, 0.01);
  cam.close();

  // Through an .oni file: the same.
  const std::string oni = (src.dir.path() / "det.oni").string();
  record_oni(src.uri(), oni, 7);
  OpenNI2Camera player(device_options(oni));
  REQUIRE(player.open().ok());
  REQUIRE(player.start().ok());
  Frame played = xtion_from(player);
  CHECK(test::same_pixels(played.depth, replayed->depth));
  played.T_base_camera = replayed->T_base_camera;
  test::require_same_detection(detect(played, formats, params), want_for(played), 1e-4, 0.01);
}

TEST_CASE("openni2: a 0.2 mm frame quantised to 1 mm gives the same boxes within 2 mm / 0.2 deg") {
  // The blaze frame carries 0.2 mm units; a 1 mm OpenNI depth mode rounds every pixel by up to
  // 0.5 mm. The plane fit averages that out, the outline moves by at most a quantisation step,
  // so box centres stay within 2 mm and angles within 0.2 deg of replay's.
  Source src(2);
  const auto formats = test::recipe_formats(kBlaze);
  DetectionParams params;
  auto replayed = read_frame(kBlaze);
  REQUIRE(replayed.ok());
  const Detection want = detect(*replayed, formats, params);
  OpenNI2Camera cam(device_options(src.uri(), 0.001));
  REQUIRE(cam.open().ok());
  REQUIRE(cam.start().ok());
  std::optional<Frame> f = grab_source(cam, src, 0);
  INFO("the blaze frame never came");
  REQUIRE(f.has_value());
  CHECK(f->depth_scale_m == 0.001);
  f->intrinsics = replayed->intrinsics;  // compare the depth path alone
  f->T_base_camera = replayed->T_base_camera;
  test::require_same_detection(detect(*f, formats, params), want, 0.002, 0.2);
}

TEST_CASE("openni2: palletctl grab --config with an openni2 camera writes the frames") {
  Source src(1);
  const fs::path yaml = src.dir.path() / "openni2.yaml";
  std::ofstream(yaml) << "camera:\n  driver: openni2\n  openni2:\n    uri: \"" << src.uri() << "\"\n";
  const fs::path out = src.dir.path() / "grab";
  const fs::path log = src.dir.path() / "palletctl.out";
  const std::string cmd = "LD_LIBRARY_PATH=" + std::string(PALLETD_ONI_RUNTIME) + " " + PALLETD_BINARY_DIR +
                          "/src/palletctl/palletctl grab --config " + yaml.string() + " -n 3 --out " + out.string() +
                          " > " + log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  INFO(text);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  auto stems = list_frame_stems(out.string());
  REQUIRE(stems.ok());
  REQUIRE(stems->size() == 3);
  for (const auto& stem : *stems) {
    auto f = read_frame(stem);
    REQUIRE(f.ok());
    CHECK(match_source(*f, src.served) >= 0);
    CHECK(f->has_intensity());
  }
}

TEST_CASE("openni2: a consumer slower than the frame rate still gets each depth frame's own IR") {
  // Grabs three frame periods apart: the old wait-for-the-next-IR-frame pairing found the IR
  // stream already past the depth frame here and delivered it without intensity.
  Source src(1);
  OpenNI2Camera cam(device_options(src.uri()));
  REQUIRE(cam.open().ok());
  REQUIRE(cam.start().ok());
  for (int i = 0; i < 6; ++i) {
    std::this_thread::sleep_for(milliseconds(100));
    auto f = cam.grab(milliseconds(3000));
    INFO(cam.last_error());
    REQUIRE(f.ok());
    const int k = match_source(*f, src.served);
    REQUIRE(k >= 0);
    REQUIRE(f->has_intensity());
    CHECK(test::same_pixels(f->intensity, src.served[static_cast<std::size_t>(k)].intensity));
  }
  CHECK(cam.frames_without_ir() == 0);
  CHECK(cam.counters().drops > 0);  // the newest frame each time: the ones in between are skipped
  REQUIRE(cam.stop().ok());
  // Stopped and started again: no frame of before the stop is delivered, pairing goes on.
  REQUIRE(cam.start().ok());
  grab_and_match(cam, src, 3, 0.001, true);
  cam.close();
}
