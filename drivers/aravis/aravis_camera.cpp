// The Aravis driver (see aravis_camera.hpp): closing, streaming and grabbing. Opening and
// configuring the camera: aravis_camera_open.cpp.
#include "aravis/aravis_camera.hpp"

#include <arv.h>

#include <cmath>
#include <cstring>
#include <utility>

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

AravisCamera::~AravisCamera() { close(); }

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
