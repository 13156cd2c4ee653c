#include "aravis/aravis_camera.hpp"

#include <arv.h>

#include <cmath>
#include <cstring>
#include <utility>

#include "aravis/depth_convert.hpp"

namespace palletd {

namespace {

/// Owns one reference of a GObject.
template <typename T>
struct GObjectUnref {
  void operator()(T* p) const {
    if (p != nullptr) g_object_unref(p);
  }
};
template <typename T>
using GPtr = std::unique_ptr<T, GObjectUnref<T>>;

/// Takes a GError's message and frees it; "" when there was none.
std::string take(GError*& error) {
  if (error == nullptr) return {};
  std::string message = error->message != nullptr ? error->message : "unknown error";
  g_clear_error(&error);
  return message;
}

std::string str_or(const char* s, const char* fallback) { return s != nullptr ? s : fallback; }

}  // namespace

struct AravisCamera::Impl {
  GPtr<ArvCamera> camera;
  GPtr<ArvStream> stream;
  gulong control_lost_handler = 0;
  std::atomic<bool> control_lost{false};
  bool unreachable = false;  ///< a control-channel call timed out: do not talk to it on close
  ArvPixelFormat pixel_format = 0;
  aravis::Scan3dParams scan3d;
  Intrinsics intrinsics;
  std::string camera_id;
  // Stream statistics folded in when a stream is destroyed (counters survive reconnects).
  std::uint64_t drops_base = 0;
  std::uint64_t resent_base = 0;

  bool feature(const char* name) const {
    GError* error = nullptr;
    const gboolean available = arv_camera_is_feature_available(camera.get(), name, &error);
    g_clear_error(&error);
    return available != FALSE;
  }
  std::optional<double> get_float(const char* name) const {
    if (!feature(name)) return std::nullopt;
    GError* error = nullptr;
    const double v = arv_camera_get_float(camera.get(), name, &error);
    if (error != nullptr) {
      g_clear_error(&error);
      // Some cameras publish these as Integer features.
      const gint64 i = arv_camera_get_integer(camera.get(), name, &error);
      if (error != nullptr) {
        g_clear_error(&error);
        return std::nullopt;
      }
      return static_cast<double>(i);
    }
    return v;
  }
};

namespace {

void on_control_lost(ArvDevice* /*device*/, gpointer user_data) {
  static_cast<std::atomic<bool>*>(user_data)->store(true);
}

}  // namespace

AravisCamera::AravisCamera(AravisOptions options)
    : options_(std::move(options)), impl_(std::make_unique<Impl>()) {
  CameraIdentity id;
  id.driver = "aravis";
  id.serial = options_.serial.empty() ? options_.user_id : options_.serial;
  id.address = options_.address;
  set_identity(std::move(id));
}

AravisCamera::~AravisCamera() { close(); }

Status AravisCamera::do_open() {
  GError* error = nullptr;
  const std::string name = !options_.address.empty() ? options_.address
                           : !options_.serial.empty() ? options_.serial
                                                      : options_.user_id;
  // All empty: the first camera discovery finds (commissioning with one camera on the link).
  impl_->camera.reset(arv_camera_new(name.empty() ? nullptr : name.c_str(), &error));
  if (!impl_->camera) {
    return Error{"aravis: cannot open camera '" + (name.empty() ? std::string("(first found)") : name) +
                 "': " + take(error)};
  }
  ArvCamera* cam = impl_->camera.get();
  if (!arv_camera_is_gv_device(cam)) return Error{"aravis: '" + name + "' is not a GigE Vision camera"};

  CameraIdentity id;
  id.driver = "aravis";
  id.vendor = str_or(arv_camera_get_vendor_name(cam, &error), "");
  g_clear_error(&error);
  id.model = str_or(arv_camera_get_model_name(cam, &error), "");
  g_clear_error(&error);
  id.serial = str_or(arv_camera_get_device_serial_number(cam, &error), "");
  g_clear_error(&error);
  ArvDevice* device = arv_camera_get_device(cam);
  {
    GSocketAddress* address = arv_gv_device_get_device_address(ARV_GV_DEVICE(device));
    if (address != nullptr) {
      GInetAddress* inet = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(address));
      gchar* text = g_inet_address_to_string(inet);
      id.address = text != nullptr ? text : "";
      g_free(text);
    }
  }
  if (!options_.serial.empty() && id.serial != options_.serial) {
    return Error{"aravis: camera at " + id.address + " has serial '" + id.serial +
                 "', configured '" + options_.serial + "'"};
  }
  if (!options_.user_id.empty() && impl_->feature("DeviceUserID")) {
    const std::string user = str_or(arv_camera_get_string(cam, "DeviceUserID", &error), "");
    g_clear_error(&error);
    if (user != options_.user_id) {
      return Error{"aravis: camera at " + id.address + " has user id '" + user + "', configured '" +
                   options_.user_id + "'"};
    }
  }
  impl_->camera_id = id.id();
  set_identity(id);

  impl_->control_lost = false;
  impl_->control_lost_handler =
      g_signal_connect(device, "control-lost", G_CALLBACK(on_control_lost), &impl_->control_lost);

  // Pixel format.
  arv_camera_set_pixel_format_from_string(cam, options_.pixel_format.c_str(), &error);
  if (error != nullptr) {
    return Error{"aravis: camera " + impl_->camera_id + " refuses PixelFormat " +
                 options_.pixel_format + ": " + take(error)};
  }
  impl_->pixel_format = arv_camera_get_pixel_format(cam, &error);
  if (error != nullptr) return Error{"aravis: cannot read PixelFormat: " + take(error)};

  // Scan3d description of the depth coordinate.
  aravis::Scan3dParams p;
  if (impl_->pixel_format == ARV_PIXEL_FORMAT_MONO_16) {
    p.scale = options_.mono16_scale_m;
    p.unit_m = 1.0;
  } else {
    if (impl_->feature("Scan3dCoordinateSelector")) {
      arv_camera_set_string(cam, "Scan3dCoordinateSelector", "CoordinateC", &error);
      g_clear_error(&error);
    }
    if (auto v = impl_->get_float("Scan3dCoordinateScale")) p.scale = *v;
    if (auto v = impl_->get_float("Scan3dCoordinateOffset")) p.offset = *v;
    if (impl_->feature("Scan3dDistanceUnit")) {
      const std::string unit = str_or(arv_camera_get_string(cam, "Scan3dDistanceUnit", &error), "");
      g_clear_error(&error);
      if (unit == "Meter") p.unit_m = 1.0;
      else if (unit == "Inch") p.unit_m = 0.0254;
      else if (unit == "Micrometer") p.unit_m = 1e-6;
      else p.unit_m = 0.001;  // Millimeter, the SFNC default
    }
    if (impl_->feature("Scan3dInvalidDataFlag") || impl_->feature("Scan3dInvalidDataValue")) {
      p.invalid = impl_->get_float("Scan3dInvalidDataValue");
    }
    if (!(p.scale > 0.0)) {
      return Error{"aravis: camera " + impl_->camera_id + " reports Scan3dCoordinateScale " +
                   std::to_string(p.scale)};
    }
  }
  impl_->scan3d = p;

  // Intrinsics: the configuration wins, then the camera's Scan3d features.
  gint x = 0, y = 0, width = 0, height = 0;
  arv_camera_get_region(cam, &x, &y, &width, &height, &error);
  if (error != nullptr) return Error{"aravis: cannot read the image region: " + take(error)};
  if (options_.intrinsics_override) {
    impl_->intrinsics = *options_.intrinsics_override;
  } else {
    const auto f = impl_->get_float("Scan3dFocalLength");
    const auto u = impl_->get_float("Scan3dPrincipalPointU");
    const auto v = impl_->get_float("Scan3dPrincipalPointV");
    if (!f || !u || !v || !(*f > 0.0)) {
      return Error{"aravis: camera " + impl_->camera_id +
                   " has no Scan3dFocalLength/Scan3dPrincipalPointU/V; set camera.intrinsics"};
    }
    impl_->intrinsics = Intrinsics{};
    impl_->intrinsics.fx = impl_->intrinsics.fy = *f;
    impl_->intrinsics.cx = *u;
    impl_->intrinsics.cy = *v;
  }
  impl_->intrinsics.width = width;
  impl_->intrinsics.height = height;
  if (options_.intrinsics_override &&
      (options_.intrinsics_override->width != width || options_.intrinsics_override->height != height)) {
    return Error{"aravis: camera image is " + std::to_string(width) + "x" + std::to_string(height) +
                 ", configured intrinsics are for " + std::to_string(options_.intrinsics_override->width) +
                 "x" + std::to_string(options_.intrinsics_override->height)};
  }

  // Trigger mode.
  const bool sw = options_.software_trigger && arv_camera_is_software_trigger_supported(cam, &error);
  g_clear_error(&error);
  if (sw) {
    arv_camera_set_trigger(cam, "Software", &error);
    if (error != nullptr) return Error{"aravis: cannot set software trigger: " + take(error)};
  } else {
    arv_camera_clear_triggers(cam, &error);
    g_clear_error(&error);
  }
  arv_camera_set_acquisition_mode(cam, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
  if (error != nullptr) return Error{"aravis: cannot set AcquisitionMode: " + take(error)};
  trigger_mode_ = sw;

  // Packet size.
  if (options_.packet_size > 0) {
    arv_camera_gv_set_packet_size(cam, options_.packet_size, &error);
    if (error != nullptr) {
      return Error{"aravis: cannot set packet size " + std::to_string(options_.packet_size) + ": " +
                   take(error)};
    }
  } else {
    arv_camera_gv_auto_packet_size(cam, &error);
    g_clear_error(&error);  // the camera keeps its packet size
  }
  return {};
}

Status AravisCamera::do_start() {
  ArvCamera* cam = impl_->camera.get();
  GError* error = nullptr;
  impl_->stream.reset(arv_camera_create_stream(cam, nullptr, nullptr, &error));
  if (!impl_->stream) return Error{"aravis: cannot create the stream: " + take(error)};
  if (ARV_IS_GV_STREAM(impl_->stream.get())) {
    g_object_set(impl_->stream.get(), "packet-resend",
                 options_.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS
                                        : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                 nullptr);
  }
  const guint payload = arv_camera_get_payload(cam, &error);
  if (error != nullptr) return Error{"aravis: cannot read PayloadSize: " + take(error)};
  for (int i = 0; i < std::max(options_.buffer_count, 2); ++i) {
    arv_stream_push_buffer(impl_->stream.get(), arv_buffer_new_allocate(payload));
  }
  arv_camera_start_acquisition(cam, &error);
  if (error != nullptr) return Error{"aravis: AcquisitionStart failed: " + take(error)};
  timeouts_in_row_ = 0;
  return {};
}

void AravisCamera::update_stream_counters() {
  if (!impl_->stream) return;
  guint64 completed = 0, failures = 0, underruns = 0;
  arv_stream_get_statistics(impl_->stream.get(), &completed, &failures, &underruns);
  drops_ = impl_->drops_base + underruns;
  if (ARV_IS_GV_STREAM(impl_->stream.get())) {
    guint64 resent = 0, missing = 0;
    arv_gv_stream_get_statistics(ARV_GV_STREAM(impl_->stream.get()), &resent, &missing);
    resent_ = impl_->resent_base + resent;
  }
}

Status AravisCamera::do_stop() {
  GError* error = nullptr;
  if (impl_->camera) arv_camera_stop_acquisition(impl_->camera.get(), &error);
  update_stream_counters();
  impl_->drops_base = drops_.load();
  impl_->resent_base = resent_.load();
  impl_->stream.reset();
  if (error != nullptr) return Error{"aravis: AcquisitionStop failed: " + take(error)};
  return {};
}

void AravisCamera::do_close() {
  if (impl_->stream) {
    GError* error = nullptr;
    // A camera that did not answer would make AcquisitionStop wait out the GVCP retries again.
    if (impl_->camera && !impl_->control_lost && !impl_->unreachable) {
      arv_camera_stop_acquisition(impl_->camera.get(), &error);
    }
    g_clear_error(&error);
    update_stream_counters();
    impl_->drops_base = drops_.load();
    impl_->resent_base = resent_.load();
    impl_->stream.reset();
  }
  if (impl_->camera && impl_->control_lost_handler != 0) {
    g_signal_handler_disconnect(arv_camera_get_device(impl_->camera.get()), impl_->control_lost_handler);
    impl_->control_lost_handler = 0;
  }
  impl_->camera.reset();
  impl_->unreachable = false;
  trigger_mode_ = false;
}

Status AravisCamera::do_software_trigger() {
  GError* error = nullptr;
  arv_camera_software_trigger(impl_->camera.get(), &error);
  if (error != nullptr) {
    // A camera that no longer answers its control channel is gone: fault it so the supervisor
    // reconnects (between triggers nothing else would notice). A GVCP timeout already means
    // Aravis resent the command several times without an answer: asking again (the probe) would
    // only block the acquisition thread for as long once more.
    const bool no_answer = error->domain == ARV_DEVICE_ERROR && error->code == ARV_DEVICE_ERROR_TIMEOUT;
    std::string why = take(error);
    if (no_answer || impl_->control_lost) {
      impl_->unreachable = true;
      mark_faulted();
    } else if (!probe_control()) {
      mark_faulted();
    }
    return Error{"aravis: TriggerSoftware failed: " + why};
  }
  return {};
}

bool AravisCamera::do_alive() const { return !impl_->control_lost; }

Status AravisCamera::probe_control() {
  if (impl_->control_lost) return Error{"control channel lost (heartbeat)"};
  ControlCall call(*this);
  GError* error = nullptr;
  (void)arv_camera_get_integer(impl_->camera.get(), "PayloadSize", &error);
  if (error != nullptr) {
    if (error->domain == ARV_DEVICE_ERROR && error->code == ARV_DEVICE_ERROR_TIMEOUT) impl_->unreachable = true;
    return Error{take(error)};
  }
  return {};
}

Expected<Frame> AravisCamera::do_grab(std::chrono::milliseconds timeout) {
  if (impl_->control_lost) {
    mark_faulted();
    return Error{"aravis: lost the control channel of camera " + impl_->camera_id};
  }
  const auto timeout_us = static_cast<guint64>(std::max<std::int64_t>(timeout.count(), 1)) * 1000u;
  ArvBuffer* buffer = arv_stream_timeout_pop_buffer(impl_->stream.get(), timeout_us);
  update_stream_counters();
  if (buffer == nullptr) {
    count_timeout();
    ++timeouts_in_row_;
    Status alive = probe_control();
    if (!alive) {
      mark_faulted();
      return Error{"aravis: camera " + impl_->camera_id + " is gone: " + alive.error()};
    }
    if (!trigger_mode_ && timeouts_in_row_ >= options_.timeouts_before_fault) {
      mark_faulted();
      return Error{"aravis: camera " + impl_->camera_id + " stopped streaming (" +
                   std::to_string(timeouts_in_row_) + " timeouts in a row)"};
    }
    return Error{"aravis: no frame from camera " + impl_->camera_id + " within " +
                 std::to_string(timeout.count()) + " ms"};
  }
  timeouts_in_row_ = 0;
  // Give the buffer back to the pool whatever happens below.
  struct Requeue {
    ArvStream* stream;
    ArvBuffer* buffer;
    ~Requeue() { arv_stream_push_buffer(stream, buffer); }
  } requeue{impl_->stream.get(), buffer};

  const ArvBufferStatus status = arv_buffer_get_status(buffer);
  if (status != ARV_BUFFER_STATUS_SUCCESS) {
    ++incomplete_;
    return Error{"aravis: incomplete frame " + std::to_string(arv_buffer_get_frame_id(buffer)) +
                 " from camera " + impl_->camera_id + " (buffer status " +
                 std::to_string(static_cast<int>(status)) + ")"};
  }
  const gint width = arv_buffer_get_image_width(buffer);
  const gint height = arv_buffer_get_image_height(buffer);
  const ArvPixelFormat format = arv_buffer_get_image_pixel_format(buffer);
  if (width != impl_->intrinsics.width || height != impl_->intrinsics.height) {
    ++incomplete_;
    return Error{"aravis: frame is " + std::to_string(width) + "x" + std::to_string(height) +
                 ", expected " + std::to_string(impl_->intrinsics.width) + "x" +
                 std::to_string(impl_->intrinsics.height)};
  }
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  size_t size = 0;
  const void* data = arv_buffer_get_image_data(buffer, &size);

  Frame frame;
  frame.intrinsics = impl_->intrinsics;
  if (format == ARV_PIXEL_FORMAT_COORD3D_C_16 || format == ARV_PIXEL_FORMAT_MONO_16) {
    if (size < n * 2) {
      ++incomplete_;
      return Error{"aravis: short 16-bit frame (" + std::to_string(size) + " bytes)"};
    }
    aravis::convert_c16(data, n, impl_->scan3d, frame);
  } else if (format == ARV_PIXEL_FORMAT_COORD3D_ABC_32F) {
    if (size < n * 12) {
      ++incomplete_;
      return Error{"aravis: short Coord3D_ABC32f frame (" + std::to_string(size) + " bytes)"};
    }
    aravis::convert_abc32f(data, n, impl_->scan3d, frame);
  } else {
    ++incomplete_;
    return Error{"aravis: unsupported pixel format 0x" + [&] {
      char b[16];
      std::snprintf(b, sizeof b, "%08x", static_cast<unsigned>(format));
      return std::string(b);
    }() + " from camera " + impl_->camera_id};
  }

  // Intensity / confidence from a second part of a multipart buffer, when there is one.
  const guint parts = arv_buffer_get_n_parts(buffer);
  for (guint part = 1; part < parts; ++part) {
    if (arv_buffer_get_part_width(buffer, part) != width || arv_buffer_get_part_height(buffer, part) != height) {
      continue;
    }
    const ArvPixelFormat pf = arv_buffer_get_part_pixel_format(buffer, part);
    size_t part_size = 0;
    const void* part_data = arv_buffer_get_part_data(buffer, part, &part_size);
    if (pf == ARV_PIXEL_FORMAT_MONO_16 && part_size >= n * 2) {
      frame.intensity.resize(n);
      std::memcpy(frame.intensity.data(), part_data, n * 2);
      frame.intensity_bits = 16;
      break;
    }
    if (pf == ARV_PIXEL_FORMAT_MONO_8 && part_size >= n) {
      const auto* p8 = static_cast<const std::uint8_t*>(part_data);
      frame.intensity.assign(p8, p8 + n);
      frame.intensity_bits = 8;
      break;
    }
  }

  frame.camera_id = impl_->camera_id;
  frame.sequence = sequence_++;
  const guint64 system_ns = arv_buffer_get_system_timestamp(buffer);
  frame.timestamp_ns = static_cast<std::int64_t>(system_ns);
  return frame;
}

}  // namespace palletd
