// The OpenNI2 driver (see openni2_camera.hpp).
#include "openni2/openni2_camera.hpp"

#include <OpenNI.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "openni2/frame_pairing.hpp"
#include "openni2/openni2_session.hpp"

namespace palletd {

using namespace openni2;  // the driver's private pieces (openni2_session.hpp)

bool is_oni_path(const std::string& uri) {
  if (uri.size() < 4) return false;
  std::string ext = uri.substr(uri.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".oni";
}

Intrinsics intrinsics_from_fov(int width, int height, double hfov_rad, double vfov_rad) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  if (!(hfov_rad > 0.0 && hfov_rad < M_PI && vfov_rad > 0.0 && vfov_rad < M_PI)) return k;
  k.fx = 0.5 * width / std::tan(0.5 * hfov_rad);
  k.fy = 0.5 * height / std::tan(0.5 * vfov_rad);
  k.cx = (width - 1) / 2.0;
  k.cy = (height - 1) / 2.0;
  return k;
}


struct OpenNI2Camera::Impl {
  Runtime runtime;  ///< declared first: released last
  std::unique_ptr<Session> session;
  std::string uri;  ///< the URI actually opened
  std::string camera_id;
  Intrinsics intrinsics;
  double depth_scale_m = 0.001;
  double frame_period_us = 33333.0;
};

OpenNI2Camera::OpenNI2Camera(OpenNI2Options options) : options_(std::move(options)) {
  CameraIdentity id;
  id.driver = "openni2";
  id.model = "openni2";
  id.address = options_.uri.empty() ? std::string("(first device)") : options_.uri;
  if (is_oni_path(options_.uri)) id.serial = std::filesystem::path(options_.uri).stem().string();
  set_identity(std::move(id));
}

OpenNI2Camera::~OpenNI2Camera() { close(); }

int OpenNI2Camera::recording_frame_count() const {
  return (impl_ && impl_->session && impl_->session->is_file) ? impl_->session->file_frames : 0;
}

namespace {

/// Depth units asked of a live device: below this configured unit 100 um (DEPTH_100_UM), else 1 mm.
constexpr double kDepthUnitSplit_m = 0.0005;
/// .oni playback speed: the recorded (real-time) rate.
constexpr float kRealTimeSpeed = 1.0f;
/// Room for the serial number a device reports (including its terminating NUL) [chars].
constexpr std::size_t kSerialChars = 256;
/// One second [us].
constexpr double kSecond_us = 1e6;

/// Opens the device (or .oni recording) the options name and creates its depth stream.
Status open_device_and_depth(Session& s, const OpenNI2Options& options) {
  const bool file = is_oni_path(options.uri);
  if (file && !std::filesystem::is_regular_file(options.uri)) {
    return Error{"openni2: recording " + options.uri + " does not exist"};
  }
  const char* uri = options.uri.empty() ? openni::ANY_DEVICE : options.uri.c_str();
  if (s.device.open(uri) != openni::STATUS_OK) {
    return Error{"openni2: cannot open " + (options.uri.empty() ? std::string("the first device") : options.uri) +
                 ": " + oni_error()};
  }
  s.is_file = s.device.isFile();
  if (!s.device.hasSensor(openni::SENSOR_DEPTH)) {
    return Error{"openni2: " + std::string(s.device.getDeviceInfo().getUri()) + " has no depth sensor"};
  }
  if (s.depth.create(s.device, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
    return Error{"openni2: cannot create the depth stream: " + oni_error()};
  }
  return {};
}

/// .oni recording: real-time playback without repeat; counts the depth frames it holds.
Status configure_playback(Session& s, const OpenNI2Options& options) {
  openni::PlaybackControl* playback = s.device.getPlaybackControl();
  if (playback == nullptr) return Error{"openni2: " + options.uri + " opened without playback control"};
  // Real-time playback; never -1 (manual stepping hangs waitForAnyStream in OpenNI2 2.2), and
  // no built-in repeat: the end of the file is found by frame index and rewound by reopening.
  if (playback->setSpeed(kRealTimeSpeed) != openni::STATUS_OK ||
      playback->setRepeatEnabled(false) != openni::STATUS_OK) {
    return Error{"openni2: cannot set up playback of " + options.uri + ": " + oni_error()};
  }
  s.file_frames = playback->getNumberOfFrames(s.depth);
  if (s.file_frames <= 0) return Error{"openni2: recording " + options.uri + " holds no depth frames"};
  return {};
}

/// Live device: the configured depth mode (width, height, fps and depth unit), when the device
/// offers it (the error lists the modes it does offer); mirroring off where it can be set.
Status select_depth_mode(Session& s, const OpenNI2Options& options) {
  const openni::SensorInfo& info = s.depth.getSensorInfo();
  const openni::Array<openni::VideoMode>& modes = info.getSupportedVideoModes();
  const openni::PixelFormat want =
      options.depth_unit_m < kDepthUnitSplit_m ? openni::PIXEL_FORMAT_DEPTH_100_UM : openni::PIXEL_FORMAT_DEPTH_1_MM;
  int found = -1;
  std::string listed;
  for (int i = 0; i < modes.getSize(); ++i) {
    const openni::VideoMode& m = modes[i];
    listed += (listed.empty() ? "" : ", ") + mode_text(m);
    if (found < 0 && m.getResolutionX() == options.width && m.getResolutionY() == options.height &&
        m.getFps() == options.fps && m.getPixelFormat() == want) {
      found = i;
    }
  }
  if (found < 0) {
    openni::VideoMode w;
    w.setResolution(options.width, options.height);
    w.setFps(options.fps);
    w.setPixelFormat(want);
    return Error{"openni2: depth mode " + mode_text(w) + " not offered by " + s.device.getDeviceInfo().getUri() +
                 " (it offers " + listed + "; set camera.openni2.width/height/fps/depth_unit_m)"};
  }
  if (s.depth.setVideoMode(modes[found]) != openni::STATUS_OK) {
    return Error{"openni2: device refuses depth mode " + mode_text(modes[found]) + ": " + oni_error()};
  }
  if (s.depth.isPropertySupported(openni::STREAM_PROPERTY_MIRRORING)) (void)s.depth.setMirroringEnabled(false);
  return {};
}

/// IR as intensity, where it is wanted, the device has it and the mode matches the depth image
/// (`depth_mode`): sets s.has_ir. A live device's IR stream gets a gray mode of the depth image's
/// size and mirroring off; one that does not match is destroyed again.
void open_ir_stream(Session& s, const OpenNI2Options& options, const openni::VideoMode& depth_mode) {
  if (!options.ir_as_intensity || !s.device.hasSensor(openni::SENSOR_IR) ||
      s.ir.create(s.device, openni::SENSOR_IR) != openni::STATUS_OK) {
    return;
  }
  if (!s.is_file) {
    const openni::Array<openni::VideoMode>& modes = s.ir.getSensorInfo().getSupportedVideoModes();
    for (int i = 0; i < modes.getSize(); ++i) {
      const openni::VideoMode& m = modes[i];
      if (m.getResolutionX() == depth_mode.getResolutionX() &&
          m.getResolutionY() == depth_mode.getResolutionY() &&
          (m.getPixelFormat() == openni::PIXEL_FORMAT_GRAY16 || m.getPixelFormat() == openni::PIXEL_FORMAT_GRAY8) &&
          s.ir.setVideoMode(m) == openni::STATUS_OK) {
        break;
      }
    }
    if (s.ir.isPropertySupported(openni::STREAM_PROPERTY_MIRRORING)) (void)s.ir.setMirroringEnabled(false);
  }
  const openni::VideoMode irm = s.ir.getVideoMode();
  s.has_ir = irm.getResolutionX() == depth_mode.getResolutionX() &&
             irm.getResolutionY() == depth_mode.getResolutionY() &&
             (irm.getPixelFormat() == openni::PIXEL_FORMAT_GRAY16 ||
              irm.getPixelFormat() == openni::PIXEL_FORMAT_GRAY8);
  if (!s.has_ir && !s.is_file) s.ir.destroy();  // a file's streams go with its device (~Session)
}

/// Intrinsics: configured (they must be for the depth image's size), else from the depth
/// stream's field of view.
Expected<Intrinsics> depth_intrinsics(Session& s, const OpenNI2Options& options,
                                      const openni::VideoMode& mode) {
  Intrinsics k;
  if (options.intrinsics_override) {
    k = *options.intrinsics_override;
    if (k.width != mode.getResolutionX() || k.height != mode.getResolutionY()) {
      return Error{"openni2: configured intrinsics are " + std::to_string(k.width) + "x" + std::to_string(k.height) +
                   " but the depth stream is " + mode_text(mode)};
    }
  } else {
    k = intrinsics_from_fov(mode.getResolutionX(), mode.getResolutionY(), s.depth.getHorizontalFieldOfView(),
                            s.depth.getVerticalFieldOfView());
    if (!k.valid()) {
      return Error{"openni2: " + std::string(s.device.getDeviceInfo().getUri()) +
                   " reports no usable field of view; configure camera.intrinsics"};
    }
  }
  return k;
}

/// Who the device is: vendor, model and URI from `info` (the device's); the serial number where
/// a live device reports one, else the recording's file name (.oni) or the URI.
CameraIdentity read_identity(Session& s, const openni::DeviceInfo& info, const OpenNI2Options& options) {
  CameraIdentity id;
  id.driver = "openni2";
  id.vendor = info.getVendor();
  id.model = info.getName();
  id.address = info.getUri();
  char serial[kSerialChars] = {};
  int serial_size = static_cast<int>(sizeof(serial) - 1);
  if (!s.is_file && s.device.isPropertySupported(openni::DEVICE_PROPERTY_SERIAL_NUMBER) &&
      s.device.getProperty(openni::DEVICE_PROPERTY_SERIAL_NUMBER, serial, &serial_size) == openni::STATUS_OK) {
    id.serial = std::string(serial, strnlen(serial, sizeof(serial)));
  }
  if (id.serial.empty()) id.serial = s.is_file ? std::filesystem::path(options.uri).stem().string() : id.address;
  if (id.model.empty()) id.model = "openni2";
  return id;
}

}  // namespace

/// Opens the device or .oni recording and sets up its streams (depth in the configured mode or
/// real-time playback, IR where wanted), then works out the intrinsics and the identity. The
/// session goes to impl_ only when all of it worked (on an error it is torn down here).
Status OpenNI2Camera::open_device() {
  auto s = std::make_unique<Session>();
  if (Status st = open_device_and_depth(*s, options_); !st) return st;
  if (Status st = s->is_file ? configure_playback(*s, options_) : select_depth_mode(*s, options_); !st) {
    return st;
  }

  const openni::VideoMode mode = s->depth.getVideoMode();
  const double scale = depth_scale_of(mode.getPixelFormat());
  if (scale <= 0.0) {
    return Error{"openni2: depth stream delivers " + mode_text(mode) + "; palletd takes 1mm or 100um depth"};
  }
  open_ir_stream(*s, options_, mode);
  const Expected<Intrinsics> k = depth_intrinsics(*s, options_, mode);
  if (!k) return Error{k.error()};

  const openni::DeviceInfo& info = s->device.getDeviceInfo();
  CameraIdentity id = read_identity(*s, info, options_);
  impl_->uri = info.getUri();
  impl_->camera_id = id.id();
  impl_->intrinsics = *k;
  impl_->depth_scale_m = scale;
  impl_->frame_period_us = kSecond_us / std::max(1, mode.getFps());
  impl_->session = std::move(s);
  set_identity(std::move(id));
  return {};
}

Status OpenNI2Camera::start_streams() {
  Session& s = *impl_->session;
  s.listen(s.depth, s.depth_listener, s.depth_listening);
  if (!s.depth_listening) return Error{"openni2: cannot listen to the depth stream: " + oni_error()};
  if (s.depth.start() != openni::STATUS_OK) return Error{"openni2: depth stream does not start: " + oni_error()};
  if (s.has_ir) {
    s.listen(s.ir, s.ir_listener, s.ir_listening);
    if (!s.ir_listening || s.ir.start() != openni::STATUS_OK) {
      // Many structured-light devices cannot stream depth and IR at once: go on without intensity.
      Session::unlisten(s.ir, s.ir_listener, s.ir_listening);
      if (!s.is_file) s.ir.destroy();  // a file's streams go with its device (~Session)
      s.has_ir = false;
    }
  }
  return {};
}

Status OpenNI2Camera::do_open() {
  impl_ = std::make_unique<Impl>();
  if (Status st = impl_->runtime.acquire(); !st) return st;
  timeouts_in_row_ = 0;
  return open_device();
}

Status OpenNI2Camera::do_start() {
  timeouts_in_row_ = 0;
  return start_streams();
}

Status OpenNI2Camera::do_stop() {
  Session& s = *impl_->session;
  s.stop_listening();  // first: no callback may read a stream that stops under it
  if (s.has_ir) s.ir.stop();
  s.depth.stop();
  return {};
}

void OpenNI2Camera::do_close() {
  if (impl_) impl_->session.reset();
  impl_.reset();  // releases the runtime last
}

Expected<Frame> OpenNI2Camera::rewind_and_grab(std::chrono::milliseconds timeout) {
  // PlaybackControl::seek() crashes in OpenNI2 2.2: reopen the file instead.
  impl_->session.reset();
  if (Status st = open_device(); !st) {
    mark_faulted();
    return Error{st.error()};
  }
  if (Status st = start_streams(); !st) {
    mark_faulted();
    return Error{st.error()};
  }
  ++rewinds_;
  return do_grab(timeout);
}

namespace {

/// The IR frame as the frame's intensity (Gray16 or 8-bit, the depth's size); false when it does
/// not fit.
bool take_intensity(const openni::VideoFrameRef& ir, const openni::VideoFrameRef& depth, Frame& frame) {
  const bool gray16 = ir.getVideoMode().getPixelFormat() == openni::PIXEL_FORMAT_GRAY16;
  if (ir.getWidth() != depth.getWidth() || ir.getHeight() != depth.getHeight() ||
      !frame_fits(ir, gray16 ? 2 : 1)) {
    return false;
  }
  if (gray16) {
    copy_rows<std::uint16_t>(ir, frame.intensity);
  } else {
    copy_rows<std::uint8_t>(ir, frame.intensity);
  }
  frame.intensity_bits = gray16 ? 16 : 8;
  return true;
}

/// The IR frame of the same instant as `depth` (device timestamps within half a frame period),
/// from the IR ring; waits a few frame periods (within the grab's deadline) for one still on its
/// way. When the partner is lost (OpenNI keeps one unread frame per stream, so a late callback can
/// miss one), a newer depth frame that comes within that wait replaces `depth` (the skipped one
/// counts as a drop); else none, and the depth frame goes out without intensity.
std::optional<Pairing::Entry> ir_partner(Pairing& pairing, Pairing::Entry& depth, double frame_period_us,
                                         Pairing::Clock::time_point deadline) {
  const auto ir_wait = std::chrono::microseconds(
      std::max<std::int64_t>(static_cast<std::int64_t>(kIrWaitPeriods * frame_period_us), kIrWaitMin_us));
  const auto ir_deadline = std::min(deadline, Pairing::Clock::now() + ir_wait);
  const auto tolerance_us = static_cast<std::uint64_t>(0.5 * frame_period_us);
  std::optional<Pairing::Entry> partner;
  while (!(partner = pairing.take_ir_partner(depth.timestamp_us, tolerance_us, ir_deadline))) {
    std::optional<Pairing::Entry> newer = pairing.take_depth(ir_deadline);
    if (!newer) break;
    depth = std::move(*newer);
  }
  return partner;
}

}  // namespace

Expected<Frame> OpenNI2Camera::do_grab(std::chrono::milliseconds timeout) {
  const auto deadline = Pairing::Clock::now() + std::max(timeout, std::chrono::milliseconds(0));
  Session* s = impl_->session.get();
  if (s->is_file && s->last_index >= s->file_frames) {
    if (!options_.loop) {
      return Error{"openni2: end of recording " + options_.uri + " after " + std::to_string(s->file_frames) +
                   " frames (loop is off)"};
    }
    return rewind_and_grab(timeout);
  }

  std::optional<Pairing::Entry> taken = s->pairing.take_depth(deadline);
  if (!taken) return no_depth(timeout);
  timeouts_in_row_ = 0;

  const std::optional<Pairing::Entry> partner =
      s->has_ir ? ir_partner(s->pairing, *taken, impl_->frame_period_us, deadline) : std::nullopt;

  const openni::VideoFrameRef& depth = *taken->frame;
  if (!frame_fits(depth, 2)) {
    ++incomplete_;
    return Error{"openni2: unreadable depth frame from " + impl_->camera_id};
  }
  // Frames skipped since the last one delivered (an .oni file numbers its frames from 1).
  const int index = depth.getFrameIndex();
  if ((s->last_index > 0 || s->is_file) && index > s->last_index + 1) {
    drops_ += static_cast<std::uint64_t>(index - s->last_index - 1);
  }
  s->last_index = std::max(s->last_index, index);
  if (depth.getWidth() != impl_->intrinsics.width || depth.getHeight() != impl_->intrinsics.height) {
    ++incomplete_;
    return Error{"openni2: depth frame is " + std::to_string(depth.getWidth()) + "x" + std::to_string(depth.getHeight()) +
                 ", expected " + std::to_string(impl_->intrinsics.width) + "x" + std::to_string(impl_->intrinsics.height) +
                 " (cropping is not supported)"};
  }
  const double scale = depth_scale_of(depth.getVideoMode().getPixelFormat());
  if (scale <= 0.0) {
    ++incomplete_;
    return Error{"openni2: depth frame in format " + mode_text(depth.getVideoMode())};
  }

  Frame frame;
  frame.intrinsics = impl_->intrinsics;
  frame.depth_scale_m = scale;
  copy_rows<std::uint16_t>(depth, frame.depth);

  if (s->has_ir && !(partner && take_intensity(*partner->frame, depth, frame))) ++without_ir_;

  frame.camera_id = impl_->camera_id;
  frame.sequence = sequence_++;
  frame.timestamp_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                           std::chrono::system_clock::now().time_since_epoch())
                           .count();
  return frame;
}

Error OpenNI2Camera::no_depth(std::chrono::milliseconds timeout) {
  count_timeout();
  std::string why = "openni2: no depth frame from " + impl_->camera_id + " within " +
                    std::to_string(timeout.count()) + " ms";
  if (impl_->session->is_file) return Error{why};
  ++timeouts_in_row_;
  bool present = false;
  openni::Array<openni::DeviceInfo> devices;
  openni::OpenNI::enumerateDevices(&devices);
  for (int i = 0; i < devices.getSize(); ++i) present = present || impl_->uri == devices[i].getUri();
  if (!present) {
    mark_faulted();
    return Error{why + " (device " + impl_->uri + " is gone)"};
  }
  if (timeouts_in_row_ >= options_.timeouts_before_fault) {
    mark_faulted();
    return Error{why + " (" + std::to_string(timeouts_in_row_) + " timeouts in a row: stream stopped)"};
  }
  return Error{why};
}

}  // namespace palletd
