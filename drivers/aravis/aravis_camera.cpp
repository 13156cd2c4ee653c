// The Aravis driver (see aravis_camera.hpp): closing, streaming and grabbing. Opening and
// configuring the camera: aravis_camera_open.cpp.
#include "aravis/aravis_camera.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <utility>

#include <arv.h>

#include "aravis/aravis_camera_impl.hpp"
#include "aravis/depth_convert.hpp"

namespace palletd {

using aravis::take;

AravisCamera::AravisCamera(AravisOptions options)
    : options_(std::move(options)), impl_(std::make_unique<Impl>()) {
  CameraIdentity id;
  id.driver = "aravis";
  id.serial = options_.serial.empty() ? options_.user_id : options_.serial;
  id.address = options_.address;
  set_identity(std::move(id));
}

AravisCamera::~AravisCamera() {
  close();
  // A heartbeat thread that reported the control lost may still be inside that emission.
  if (impl_->closed_device && impl_->control_lost)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  impl_->closed_device.reset();
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
  if (impl_->camera) {
    ArvDevice* device = arv_camera_get_device(impl_->camera.get());
    if (impl_->control_lost_handler != 0) g_signal_handler_disconnect(device, impl_->control_lost_handler);
    impl_->control_lost_handler = 0;
    impl_->closed_device.reset(ARV_DEVICE(g_object_ref(device)));  // released at the next open
  }
  impl_->camera.reset();
  impl_->unreachable = false;
  trigger_mode_ = false;
}

Status AravisCamera::do_software_trigger() {
  // A frame already waiting was exposed before this trigger (a late answer to an earlier one, or
  // sent before the camera stopped): the trigger's frame must show the pallet as it is now.
  while (ArvBuffer* stale = arv_stream_try_pop_buffer(impl_->stream.get())) {
    arv_stream_push_buffer(impl_->stream.get(), stale);
  }
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

namespace {

std::string hex32(unsigned value) {
  char text[16];
  std::snprintf(text, sizeof text, "%08x", value);
  return text;
}

/// The depth of a complete buffer of the expected size, converted into `frame` (Coord3D_C16 or
/// Mono16 scaled by the Scan3d parameters, or Coord3D_ABC32f's Z); an error names what is wrong.
Status take_depth(ArvBuffer* buffer, std::size_t n, const aravis::Scan3dParams& scan3d,
                  const std::string& camera_id, Frame& frame) {
  const ArvPixelFormat format = arv_buffer_get_image_pixel_format(buffer);
  size_t size = 0;
  const void* data = arv_buffer_get_image_data(buffer, &size);
  if (format == ARV_PIXEL_FORMAT_COORD3D_C_16 || format == ARV_PIXEL_FORMAT_MONO_16) {
    if (size < n * 2) {
      return Error{"aravis: short 16-bit frame (" + std::to_string(size) + " bytes)"};
    }
    aravis::convert_c16(data, n, scan3d, frame);
    return {};
  }
  if (format == ARV_PIXEL_FORMAT_COORD3D_ABC_32F) {
    if (size < n * 12) {
      return Error{"aravis: short Coord3D_ABC32f frame (" + std::to_string(size) + " bytes)"};
    }
    aravis::convert_abc32f(data, n, scan3d, frame);
    return {};
  }
  return Error{"aravis: unsupported pixel format 0x" + hex32(static_cast<unsigned>(format)) +
               " from camera " + camera_id};
}

/// Intensity / confidence from a later part of a multipart buffer (Mono16 or Mono8 of the depth's
/// size), when there is one.
void take_intensity(ArvBuffer* buffer, gint width, gint height, Frame& frame) {
  const auto n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
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
      return;
    }
    if (pf == ARV_PIXEL_FORMAT_MONO_8 && part_size >= n) {
      const auto* p8 = static_cast<const std::uint8_t*>(part_data);
      frame.intensity.assign(p8, p8 + n);
      frame.intensity_bits = 8;
      return;
    }
  }
}

/// A popped buffer as a frame (without its sequence number), or why it is none: incomplete, of
/// another size than the camera's, or of a pixel format palletd does not read.
Expected<Frame> frame_from(ArvBuffer* buffer, const Intrinsics& intrinsics,
                           const aravis::Scan3dParams& scan3d, const std::string& camera_id) {
  const ArvBufferStatus status = arv_buffer_get_status(buffer);
  if (status != ARV_BUFFER_STATUS_SUCCESS) {
    return Error{"aravis: incomplete frame " + std::to_string(arv_buffer_get_frame_id(buffer)) +
                 " from camera " + camera_id + " (buffer status " + std::to_string(static_cast<int>(status)) +
                 ")"};
  }
  const gint width = arv_buffer_get_image_width(buffer);
  const gint height = arv_buffer_get_image_height(buffer);
  if (width != intrinsics.width || height != intrinsics.height) {
    return Error{"aravis: frame is " + std::to_string(width) + "x" + std::to_string(height) + ", expected " +
                 std::to_string(intrinsics.width) + "x" + std::to_string(intrinsics.height)};
  }
  Frame frame;
  frame.intrinsics = intrinsics;
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  if (Status depth = take_depth(buffer, n, scan3d, camera_id, frame); !depth) return Error{depth.error()};
  take_intensity(buffer, width, height, frame);
  frame.camera_id = camera_id;
  frame.timestamp_ns = static_cast<std::int64_t>(arv_buffer_get_system_timestamp(buffer));
  return frame;
}

}  // namespace

Expected<Frame> AravisCamera::do_grab(std::chrono::milliseconds timeout) {
  if (impl_->control_lost) {
    mark_faulted();
    return Error{"aravis: lost the control channel of camera " + impl_->camera_id};
  }
  const auto timeout_us = static_cast<guint64>(std::max<std::int64_t>(timeout.count(), 1)) * 1000u;
  ArvBuffer* buffer = arv_stream_timeout_pop_buffer(impl_->stream.get(), timeout_us);
  update_stream_counters();
  if (buffer == nullptr) return no_frame(timeout);
  timeouts_in_row_ = 0;
  // Give the buffer back to the pool whatever happens below.
  struct Requeue {
    ArvStream* stream;
    ArvBuffer* buffer;
    ~Requeue() { arv_stream_push_buffer(stream, buffer); }
  } requeue{impl_->stream.get(), buffer};
  Expected<Frame> frame = frame_from(buffer, impl_->intrinsics, impl_->scan3d, impl_->camera_id);
  if (!frame) {
    ++incomplete_;
    return frame;
  }
  frame->sequence = sequence_++;
  return frame;
}

Error AravisCamera::no_frame(std::chrono::milliseconds timeout) {
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

}  // namespace palletd
