// The OpenNI2 driver tests' fixtures: frame folders served by the palletd test device through
// the real OpenNI2 runtime, and the checks that a grabbed frame is the one served.
#pragma once

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
#include "palletd/config/config.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/frames/frame_io.hpp"

namespace palletd::test {

namespace fs = std::filesystem;
using std::chrono::milliseconds;

inline const std::string kData = PALLETD_TEST_DATA_DIR;

inline const std::string kXtion = kData + "/22_block_600x400_xtion";           // 640x480, 1 mm, 8-bit IR
inline const std::string kBlaze = kData + "/20_interlock_400x300_blaze101";    // 640x480, 0.2 mm, 16-bit IR
inline const std::string kHelios = kData + "/21_pinwheel_315x232_corner_helios2";  // 640x480, 0.25 mm, 16-bit IR

inline void copy_frame(const std::string& stem, const fs::path& dir, const std::string& name) {
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
inline int match_source(const Frame& f, const std::vector<Frame>& served) {
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
inline std::vector<int> grab_and_match(OpenNI2Camera& cam, const Source& src, int n, double unit_m, bool with_ir) {
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
inline std::optional<Frame> grab_source(Camera& cam, const Source& src, int k) {
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
inline int record_oni(const std::string& uri, const std::string& path, int min_frames) {
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

inline OpenNI2Options device_options(const std::string& uri, double unit_m = 0.001) {
  OpenNI2Options o;
  o.uri = uri;
  o.depth_unit_m = unit_m;
  return o;
}

}  // namespace palletd::test
