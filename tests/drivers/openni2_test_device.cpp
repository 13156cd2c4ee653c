// A test fixture, not shipped: an OpenNI2 device driver (OniDriverAPI) that serves recorded
// frames (shared/spec/frames.md) as a depth camera with an IR stream, through the real OpenNI2
// runtime. The runtime loads it from the OpenNI2/Drivers folder beside the libOpenNI2 copy that
// tests/drivers/CMakeLists.txt lays out in the build tree.
//
// Devices:  "palletd-test://FOLDER" (any folder of frames, opened by URI) and, when the
// environment names one in PALLETD_OPENNI2_TEST_FRAMES, that folder announced at start-up (so
// "the first device" finds it). The frames play in name order, looping, at the video mode's fps;
// frame i has frameIndex i+1 and timestamp i * 1e6 / fps microseconds.
//
// Depth modes: the frames' size at 30 fps in DEPTH_1_MM and DEPTH_100_UM; each frame's depth is
// converted from its depth_scale to the mode's unit (rounded). IR: GRAY16 or GRAY8 (the
// intensity PNG's own depth), when the frames carry intensity. Properties: video mode, stride,
// cropping (off), field of view (from the first frame's fx/fy), min/max value, mirroring (off),
// serial number. These are what openni::Recorder records and the .oni player needs back (Debian's
// DummyDevice lacks stride and cropping, so its recordings do not play).
//
// Device property kPausePropertyId (0x70A11E70, an int): 1 pauses delivery and returns once no
// frame of the device is on its way (the depth and IR frames of one instant go out together or
// not at all), 0 resumes. Timestamps and frame indices go on counting while paused. The tests use
// it to record .oni files that start and end with a whole depth+IR pair (openni::Recorder rebases
// each stream's timestamps to that stream's first recorded frame).
#include <Driver/OniDriverAPI.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <list>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include "palletd/frames/frame_io.hpp"

#define XN_NEW(type, arg) new (std::nothrow) type(arg)
#define XN_DELETE(p) delete (p)

namespace {

constexpr const char* kScheme = "palletd-test://";
constexpr int kFps = 30;
constexpr int kPausePropertyId = 0x70A11E70;

/// The frames of one folder, converted once to what the streams deliver.
struct Recording {
  int width = 0, height = 0;
  float hfov_rad = 0.0f, vfov_rad = 0.0f;
  std::vector<std::vector<std::uint16_t>> depth_1mm, depth_100um, ir;
  int ir_bits = 0;  ///< 0 = no IR stream

  std::string load(const std::string& folder) {
    auto stems = palletd::list_frame_stems(folder);
    if (!stems) return stems.error();
    if (stems->empty()) return "no frames in " + folder;
    for (const std::string& stem : *stems) {
      auto f = palletd::read_frame(stem);
      if (!f) return f.error();
      if (depth_1mm.empty()) {
        width = f->intrinsics.width;
        height = f->intrinsics.height;
        hfov_rad = static_cast<float>(2.0 * std::atan(0.5 * width / f->intrinsics.fx));
        vfov_rad = static_cast<float>(2.0 * std::atan(0.5 * height / f->intrinsics.fy));
        ir_bits = f->intensity_bits;
      }
      if (f->intrinsics.width != width || f->intrinsics.height != height) return stem + ": size differs";
      depth_1mm.push_back(convert(*f, 0.001));
      depth_100um.push_back(convert(*f, 0.0001));
      if (ir_bits != 0 && f->intensity_bits != ir_bits) ir_bits = 0;
      ir.push_back(f->intensity);
    }
    return {};
  }

  static std::vector<std::uint16_t> convert(const palletd::Frame& f, double unit_m) {
    std::vector<std::uint16_t> out(f.depth.size());
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double v = std::round(f.depth[i] * f.depth_scale_m / unit_m);
      out[i] = static_cast<std::uint16_t>(std::min(v, 65535.0));
    }
    return out;
  }
};

class TestStream : public oni::driver::StreamBase {
 public:
  TestStream(OniSensorType type, const Recording& rec, const OniSensorInfo& info)
      : type_(type), rec_(rec), info_(info), mode_(info.pSupportedVideoModes[0]) {}

  OniStatus start() override {
    std::lock_guard<std::mutex> lock(state_mutex_);
    running_ = true;
    return ONI_STATUS_OK;
  }
  /// After stop() returns no frame of this stream is in OpenNI's hands any more: it waits for a
  /// push under way (OpenNI calls stop() without holding its own locks, before it tears the
  /// stream down).
  void stop() override {
    std::unique_lock<std::mutex> lock(state_mutex_);
    running_ = false;
    idle_.wait(lock, [this] { return pushing_ == 0; });
  }

  int bytes_per_pixel() const { return mode_.pixelFormat == ONI_PIXEL_FORMAT_GRAY8 ? 1 : 2; }
  int getRequiredFrameSize() override { return rec_.width * rec_.height * bytes_per_pixel(); }

  OniBool isPropertySupported(int id) override {
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE: case ONI_STREAM_PROPERTY_CROPPING:
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV: case ONI_STREAM_PROPERTY_VERTICAL_FOV:
      case ONI_STREAM_PROPERTY_STRIDE: case ONI_STREAM_PROPERTY_MAX_VALUE:
      case ONI_STREAM_PROPERTY_MIN_VALUE: case ONI_STREAM_PROPERTY_MIRRORING:
        return TRUE;
      default:
        return FALSE;
    }
  }

  OniStatus getProperty(int id, void* data, int* size) override {
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE: return put(mode_, data, size);
      case ONI_STREAM_PROPERTY_CROPPING: return put(cropping(), data, size);
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV: return put(rec_.hfov_rad, data, size);
      case ONI_STREAM_PROPERTY_VERTICAL_FOV: return put(rec_.vfov_rad, data, size);
      case ONI_STREAM_PROPERTY_STRIDE: return put(rec_.width * bytes_per_pixel(), data, size);
      case ONI_STREAM_PROPERTY_MAX_VALUE: return put(max_value(), data, size);
      case ONI_STREAM_PROPERTY_MIN_VALUE: return put(0, data, size);
      case ONI_STREAM_PROPERTY_MIRRORING: return put(OniBool(FALSE), data, size);
      default: return ONI_STATUS_NOT_SUPPORTED;
    }
  }

  OniStatus setProperty(int id, const void* data, int size) override {
    if (id == ONI_STREAM_PROPERTY_VIDEO_MODE && size == static_cast<int>(sizeof(OniVideoMode))) {
      OniVideoMode want;
      std::memcpy(&want, data, sizeof want);
      for (int i = 0; i < info_.numSupportedVideoModes; ++i) {
        const OniVideoMode& m = info_.pSupportedVideoModes[i];
        if (m.pixelFormat == want.pixelFormat && m.resolutionX == want.resolutionX &&
            m.resolutionY == want.resolutionY && m.fps == want.fps) {
          mode_ = m;
          return ONI_STATUS_OK;
        }
      }
      return ONI_STATUS_BAD_PARAMETER;
    }
    if (id == ONI_STREAM_PROPERTY_MIRRORING && size == static_cast<int>(sizeof(OniBool))) {
      OniBool on;
      std::memcpy(&on, data, sizeof on);
      return on ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    return ONI_STATUS_NOT_SUPPORTED;
  }

  void notifyAllProperties() override {
    for (int id : {ONI_STREAM_PROPERTY_VIDEO_MODE, ONI_STREAM_PROPERTY_CROPPING, ONI_STREAM_PROPERTY_HORIZONTAL_FOV,
                   ONI_STREAM_PROPERTY_VERTICAL_FOV, ONI_STREAM_PROPERTY_STRIDE, ONI_STREAM_PROPERTY_MAX_VALUE,
                   ONI_STREAM_PROPERTY_MIN_VALUE, ONI_STREAM_PROPERTY_MIRRORING}) {
      unsigned char buffer[64];
      int size = sizeof buffer;
      if (getProperty(id, buffer, &size) == ONI_STATUS_OK) raisePropertyChanged(id, buffer, size);
    }
  }

  /// Delivers source frame `i` (counter `n`) when started. Called with no lock of ours held:
  /// raiseNewFrame takes OpenNI's locks (the stream's recorders, its frame holder), and OpenNI
  /// holds those while it calls into the driver (destroyStream) - the other order.
  void push(std::size_t i, int n) {
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      if (!running_) return;
      ++pushing_;
    }
    deliver(i, n);
    {
      std::lock_guard<std::mutex> lock(state_mutex_);
      --pushing_;
    }
    idle_.notify_all();
  }

 private:
  void deliver(std::size_t i, int n) {
    const std::vector<std::uint16_t>* src = nullptr;
    if (type_ == ONI_SENSOR_DEPTH) {
      src = mode_.pixelFormat == ONI_PIXEL_FORMAT_DEPTH_100_UM ? &rec_.depth_100um[i] : &rec_.depth_1mm[i];
    } else {
      src = &rec_.ir[i];
    }
    OniFrame* frame = getServices().acquireFrame();
    if (frame == nullptr) return;
    const int bpp = bytes_per_pixel();
    frame->dataSize = rec_.width * rec_.height * bpp;
    auto* out = static_cast<unsigned char*>(frame->data);
    for (std::size_t k = 0; k < src->size(); ++k) {
      if (bpp == 1) {
        out[k] = static_cast<unsigned char>((*src)[k]);
      } else {
        std::memcpy(out + 2 * k, &(*src)[k], 2);
      }
    }
    frame->sensorType = type_;
    frame->timestamp = static_cast<uint64_t>(n) * 1000000ull / static_cast<uint64_t>(mode_.fps);
    frame->frameIndex = n + 1;
    frame->width = rec_.width;
    frame->height = rec_.height;
    frame->videoMode = mode_;
    frame->croppingEnabled = FALSE;
    frame->cropOriginX = 0;
    frame->cropOriginY = 0;
    frame->stride = rec_.width * bpp;
    raiseNewFrame(frame);
    getServices().releaseFrame(frame);
  }

  template <typename T>
  static OniStatus put(const T& value, void* data, int* size) {
    if (*size < static_cast<int>(sizeof(T))) return ONI_STATUS_BAD_PARAMETER;
    std::memcpy(data, &value, sizeof(T));
    *size = static_cast<int>(sizeof(T));
    return ONI_STATUS_OK;
  }
  OniCropping cropping() const { return OniCropping{0, 0, 0, rec_.width, rec_.height}; }
  int max_value() const {
    if (type_ != ONI_SENSOR_DEPTH) return mode_.pixelFormat == ONI_PIXEL_FORMAT_GRAY8 ? 255 : 65535;
    return 65534;
  }

  OniSensorType type_;
  const Recording& rec_;
  const OniSensorInfo& info_;
  OniVideoMode mode_;
  std::mutex state_mutex_;
  std::condition_variable idle_;
  bool running_ = false;  ///< guarded by state_mutex_
  int pushing_ = 0;       ///< pushes under way; guarded by state_mutex_
};

class TestDevice : public oni::driver::DeviceBase {
 public:
  explicit TestDevice(Recording rec) : rec_(std::move(rec)) {
    depth_modes_[0] = OniVideoMode{ONI_PIXEL_FORMAT_DEPTH_1_MM, rec_.width, rec_.height, kFps};
    depth_modes_[1] = OniVideoMode{ONI_PIXEL_FORMAT_DEPTH_100_UM, rec_.width, rec_.height, kFps};
    ir_mode_ = OniVideoMode{rec_.ir_bits == 8 ? ONI_PIXEL_FORMAT_GRAY8 : ONI_PIXEL_FORMAT_GRAY16, rec_.width,
                            rec_.height, kFps};
    sensors_[0] = OniSensorInfo{ONI_SENSOR_DEPTH, 2, depth_modes_};
    sensors_[1] = OniSensorInfo{ONI_SENSOR_IR, 1, &ir_mode_};
    thread_ = std::thread([this] { run(); });
  }
  ~TestDevice() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  TestDevice(const TestDevice&) = delete;
  TestDevice& operator=(const TestDevice&) = delete;

  OniStatus getSensorInfoList(OniSensorInfo** infos, int* count) override {
    *infos = sensors_;
    *count = rec_.ir_bits != 0 ? 2 : 1;
    return ONI_STATUS_OK;
  }

  oni::driver::StreamBase* createStream(OniSensorType type) override {
    if (type != ONI_SENSOR_DEPTH && !(type == ONI_SENSOR_IR && rec_.ir_bits != 0)) return nullptr;
    auto s = std::make_shared<TestStream>(type, rec_, type == ONI_SENSOR_DEPTH ? sensors_[0] : sensors_[1]);
    std::lock_guard<std::mutex> lock(mutex_);
    streams_.push_back(s);
    return s.get();
  }
  /// The frame thread may still hold a reference (it pushes without the device lock); the stream
  /// is stopped by then (OpenNI stops a stream before destroying it), so that last reference only
  /// frees it.
  void destroyStream(oni::driver::StreamBase* stream) override {
    std::shared_ptr<TestStream> gone;
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = streams_.begin(); it != streams_.end(); ++it) {
      if (it->get() == stream) {
        gone = std::move(*it);
        streams_.erase(it);
        break;
      }
    }
  }

  OniBool isPropertySupported(int id) override {
    return id == ONI_DEVICE_PROPERTY_SERIAL_NUMBER || id == kPausePropertyId ? TRUE : FALSE;
  }
  OniStatus getProperty(int id, void* data, int* size) override {
    if (id != ONI_DEVICE_PROPERTY_SERIAL_NUMBER) return ONI_STATUS_NOT_SUPPORTED;
    const char serial[] = "PDONI01";
    if (*size < static_cast<int>(sizeof serial)) return ONI_STATUS_BAD_PARAMETER;
    std::memcpy(data, serial, sizeof serial);
    *size = static_cast<int>(sizeof serial);
    return ONI_STATUS_OK;
  }
  OniStatus setProperty(int id, const void* data, int size) override {
    if (id != kPausePropertyId) return ONI_STATUS_NOT_SUPPORTED;
    if (size != static_cast<int>(sizeof(int))) return ONI_STATUS_BAD_PARAMETER;
    int pause = 0;
    std::memcpy(&pause, data, sizeof pause);
    std::unique_lock<std::mutex> lock(mutex_);
    paused_ = pause != 0;
    cv_.wait(lock, [this] { return !pushing_; });  // the instant under way goes out whole
    return ONI_STATUS_OK;
  }

 private:
  void run() {
    const auto period = std::chrono::microseconds(1000000 / kFps);
    auto due = std::chrono::steady_clock::now();
    int n = 0;
    std::unique_lock<std::mutex> lock(mutex_);
    while (!quit_) {
      due += period;
      if (cv_.wait_until(lock, due, [this] { return quit_; })) break;
      const std::size_t i = static_cast<std::size_t>(n) % rec_.depth_1mm.size();
      if (!paused_) {
        // Frames go out without the device lock held (see TestStream::push).
        const std::vector<std::shared_ptr<TestStream>> streams = streams_;
        pushing_ = true;
        lock.unlock();
        for (const auto& s : streams) s->push(i, n);
        lock.lock();
        pushing_ = false;
        cv_.notify_all();
      }
      ++n;
    }
  }

  Recording rec_;
  OniVideoMode depth_modes_[2];
  OniVideoMode ir_mode_;
  OniSensorInfo sensors_[2];
  std::mutex mutex_;
  std::condition_variable cv_;
  bool quit_ = false;      ///< guarded by mutex_
  bool paused_ = false;    ///< guarded by mutex_
  bool pushing_ = false;   ///< frames of one instant on their way; guarded by mutex_
  std::vector<std::shared_ptr<TestStream>> streams_;
  std::thread thread_;
};

class TestDriver : public oni::driver::DriverBase {
 public:
  explicit TestDriver(OniDriverServices* services) : DriverBase(services) {}

  OniStatus initialize(oni::driver::DeviceConnectedCallback connected,
                       oni::driver::DeviceDisconnectedCallback disconnected,
                       oni::driver::DeviceStateChangedCallback state_changed, void* cookie) override {
    const OniStatus st = DriverBase::initialize(connected, disconnected, state_changed, cookie);
    const char* folder = std::getenv("PALLETD_OPENNI2_TEST_FRAMES");
    if (st == ONI_STATUS_OK && folder != nullptr && *folder != '\0') announce(kScheme + std::string(folder));
    return st;
  }

  /// A folder without frames is not announced: OpenNI2 2.2 allocates the device handle before
  /// deviceOpen and loses it when deviceOpen then fails (a LeakSanitizer report inside
  /// libOpenNI2); an unknown URI fails before that allocation.
  OniStatus tryDevice(const char* uri) override {
    if (uri == nullptr || std::strncmp(uri, kScheme, std::strlen(kScheme)) != 0) return ONI_STATUS_ERROR;
    auto stems = palletd::list_frame_stems(uri + std::strlen(kScheme));
    if (!stems || stems->empty()) {
      getServices().errorLoggerAppend("palletd test device %s: no frames there", uri);
      return ONI_STATUS_ERROR;
    }
    announce(uri);
    return ONI_STATUS_OK;
  }

  oni::driver::DeviceBase* deviceOpen(const char* uri, const char* /*mode*/) override {
    if (uri == nullptr || std::strncmp(uri, kScheme, std::strlen(kScheme)) != 0) return nullptr;
    Recording rec;
    const std::string error = rec.load(uri + std::strlen(kScheme));
    if (!error.empty()) {
      getServices().errorLoggerAppend("palletd test device %s: %s", uri, error.c_str());
      return nullptr;
    }
    return new TestDevice(std::move(rec));
  }
  void deviceClose(oni::driver::DeviceBase* device) override { delete device; }
  void shutdown() override {}

 private:
  void announce(const std::string& uri) {
    OniDeviceInfo info{};
    std::strncpy(info.uri, uri.c_str(), sizeof(info.uri) - 1);
    std::strncpy(info.vendor, "palletd", sizeof(info.vendor) - 1);
    std::strncpy(info.name, "palletd test device", sizeof(info.name) - 1);
    infos_.push_back(info);
    deviceConnected(&infos_.back());
  }
  std::list<OniDeviceInfo> infos_;  ///< stable addresses
};

}  // namespace

ONI_EXPORT_DRIVER(TestDriver)
