// Private to the OpenNI2 driver: the reference-counted OpenNI runtime, pixel-format helpers, the
// frame listener that fills the pairing rings, and the Session (device, streams, listeners) with
// its teardown order. Used by openni2_camera.cpp only.
#pragma once

#include <OpenNI.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "openni2/frame_pairing.hpp"
#include "palletd/core/expected.hpp"

namespace palletd::openni2 {

inline std::string oni_error() {
  const char* text = openni::OpenNI::getExtendedError();
  return (text != nullptr && *text != '\0') ? std::string(text) : std::string("no detail from OpenNI");
}

/// openni::OpenNI::initialize()/shutdown(), reference-counted across all cameras of the process.
class Runtime {
 public:
  Runtime() = default;
  ~Runtime() { release(); }
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  Status acquire() {
    if (held_) return {};
    std::lock_guard<std::mutex> lock(mutex());
    if (count() == 0 && openni::OpenNI::initialize() != openni::STATUS_OK) {
      return Error{"openni2: OpenNI2 runtime did not initialise: " + oni_error()};
    }
    ++count();
    held_ = true;
    return {};
  }
  void release() {
    if (!held_) return;
    std::lock_guard<std::mutex> lock(mutex());
    held_ = false;
    if (--count() == 0) openni::OpenNI::shutdown();
  }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static int& count() {
    static int n = 0;
    return n;
  }
  bool held_ = false;
};

inline const char* format_name(openni::PixelFormat f) {
  switch (f) {
    case openni::PIXEL_FORMAT_DEPTH_1_MM: return "1mm";
    case openni::PIXEL_FORMAT_DEPTH_100_UM: return "100um";
    case openni::PIXEL_FORMAT_SHIFT_9_2: return "shift9.2";
    case openni::PIXEL_FORMAT_SHIFT_9_3: return "shift9.3";
    case openni::PIXEL_FORMAT_GRAY8: return "gray8";
    case openni::PIXEL_FORMAT_GRAY16: return "gray16";
    case openni::PIXEL_FORMAT_RGB888: return "rgb888";
    default: return "other";
  }
}

inline std::string mode_text(const openni::VideoMode& m) {
  return std::to_string(m.getResolutionX()) + "x" + std::to_string(m.getResolutionY()) + "@" +
         std::to_string(m.getFps()) + " " + format_name(m.getPixelFormat());
}

/// [m per unit] of a depth pixel format; 0 for a format palletd does not take.
inline double depth_scale_of(openni::PixelFormat f) {
  if (f == openni::PIXEL_FORMAT_DEPTH_1_MM) return 0.001;
  if (f == openni::PIXEL_FORMAT_DEPTH_100_UM) return 0.0001;
  return 0.0;
}

/// Copies a 16-bit (or 8-bit) image row by row, honouring the stride.
template <typename Pixel>
void copy_rows(const openni::VideoFrameRef& ref, std::vector<std::uint16_t>& out) {
  const auto w = static_cast<std::size_t>(ref.getWidth());
  const auto h = static_cast<std::size_t>(ref.getHeight());
  const auto stride = static_cast<std::size_t>(ref.getStrideInBytes());
  const auto* base = static_cast<const std::uint8_t*>(ref.getData());
  out.resize(w * h);
  for (std::size_t v = 0; v < h; ++v) {
    const std::uint8_t* row = base + v * stride;
    for (std::size_t u = 0; u < w; ++u) {
      Pixel p;
      std::memcpy(&p, row + u * sizeof(Pixel), sizeof(Pixel));
      out[v * w + u] = static_cast<std::uint16_t>(p);
    }
  }
}

inline bool frame_fits(const openni::VideoFrameRef& ref, std::size_t bytes_per_pixel) {
  if (!ref.isValid() || ref.getWidth() <= 0 || ref.getHeight() <= 0) return false;
  const auto stride = static_cast<std::size_t>(ref.getStrideInBytes());
  if (stride < static_cast<std::size_t>(ref.getWidth()) * bytes_per_pixel) return false;
  return static_cast<std::size_t>(ref.getDataSize()) >= stride * static_cast<std::size_t>(ref.getHeight());
}


using Pairing = openni2::FramePairing<openni::VideoFrameRef>;

/// Depth and IR frames kept for pairing (per stream): about 130 ms at 30 fps.
constexpr std::size_t kRingFrames = 4;
/// How long a grab waits for the IR partner of its depth frame: this many frame periods, at least
/// kIrWaitMin_us (and never past the grab's timeout).
constexpr double kIrWaitPeriods = 3.0;
constexpr std::int64_t kIrWaitMin_us = 100000;
/// .oni teardown: time for OniFile's player thread to finish a frame it is delivering (~Session).
constexpr std::chrono::milliseconds kPlayerSettle{100};

/// Puts every frame of one stream into the pairing rings. OpenNI calls onNewFrame() from the
/// stream's own thread, once per wake-up of that thread: wake-ups coalesce, so a call can come
/// after its frame was already read. readFrame() would then block (it waits for a frame without
/// limit, holding the lock that removeNewFrameListener() needs), so the callback first asks
/// without waiting whether a frame is there.
class RingListener final : public openni::VideoStream::NewFrameListener {
 public:
  RingListener(Pairing& pairing, Pairing::Stream stream) : pairing_(pairing), stream_(stream) {}
  void onNewFrame(openni::VideoStream& stream) override {
    openni::VideoStream* ptr = &stream;
    int ready = -1;
    if (openni::OpenNI::waitForAnyStream(&ptr, 1, &ready, 0) != openni::STATUS_OK) return;
    auto ref = std::make_shared<openni::VideoFrameRef>();
    if (stream.readFrame(ref.get()) != openni::STATUS_OK || !ref->isValid()) return;
    Pairing::Entry entry;
    entry.timestamp_us = ref->getTimestamp();
    entry.index = ref->getFrameIndex();
    entry.frame = std::move(ref);
    pairing_.push(stream_, std::move(entry));
  }

 private:
  Pairing& pairing_;
  Pairing::Stream stream_;
};

/// The device and its streams; replaced as a whole to rewind an .oni file. Members are destroyed
/// in reverse order: listeners and held frames go before the streams they came from (a frame
/// released after its stream is gone would be handed back to a freed stream), the streams
/// (IR, depth) before the device.
struct Session {
  openni::Device device;
  openni::VideoStream depth;
  openni::VideoStream ir;
  bool has_ir = false;
  bool is_file = false;
  int file_frames = 0;   ///< depth frames in the .oni file
  int last_index = 0;    ///< frame index of the last depth frame delivered (0 = none yet)
  Pairing pairing{kRingFrames};
  RingListener depth_listener{pairing, Pairing::Stream::kDepth};
  RingListener ir_listener{pairing, Pairing::Stream::kIr};
  bool depth_listening = false;
  bool ir_listening = false;

  Session() = default;
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  /// Debian's OniFile driver (OpenNI2 2.2, .oni playback) runs a player thread per device that
  /// walks the device's stream list without a lock (PlayerDevice::MainLoop), while destroying a
  /// stream unlinks and frees it from that list: destroying the streams of an open file crashed
  /// the player thread now and then (SIGSEGV in libOniFile.so.0, about 1 run in 4 of the .oni test
  /// under TSan). Closing the device while the player is handing over a frame crashes too (SIGSEGV
  /// in libOpenNI2.so.0 under OniFile's frame delivery). So for a file: the streams are stopped,
  /// the player is given kPlayerSettle to finish a frame under way (with no stream started it only
  /// polls), and the device is closed first, which ends and joins the player thread; OniFile then
  /// drops its stream list, and OpenNI releases the stream handles without asking OniFile to
  /// destroy them (the device handle is gone), so OniFile's two small stream objects stay
  /// allocated at each close or rewind (LeakSanitizer: leak:libOniFile.so in lsan.supp).
  ~Session() {
    stop_listening();
    if (is_file) {
      if (ir.isValid()) ir.stop();
      if (depth.isValid()) depth.stop();
      std::this_thread::sleep_for(kPlayerSettle);
      device.close();
    }
  }

  /// Listeners go on before the streams start, so that no first frame is missed.
  void listen(openni::VideoStream& stream, RingListener& listener, bool& listening) {
    if (!listening) listening = stream.addNewFrameListener(&listener) == openni::STATUS_OK;
  }
  static void unlisten(openni::VideoStream& stream, RingListener& listener, bool& listening) {
    if (listening) stream.removeNewFrameListener(&listener);
    listening = false;
  }
  /// After this no callback runs any more (removal waits for one under way), and no frame of
  /// the streams is held.
  void stop_listening() {
    unlisten(ir, ir_listener, ir_listening);
    unlisten(depth, depth_listener, depth_listening);
    pairing.clear();
  }
};

}  // namespace palletd::openni2
