// The Aravis driver (see aravis_camera.hpp): opening and configuring the camera, do_open() and its
// phases. Streaming and grabbing: aravis_camera.cpp.
#include "aravis/aravis_camera.hpp"

#include <arv.h>

#include <string>

#include "aravis/aravis_camera_impl.hpp"
#include "aravis/depth_convert.hpp"

namespace palletd {

using aravis::str_or;
using aravis::take;

namespace {

// Scan3dDistanceUnit values in metres (Millimeter is the SFNC default).
constexpr double kMetre_m = 1.0;
constexpr double kMillimetre_m = 0.001;
constexpr double kMicrometre_m = 1e-6;
constexpr double kInch_m = 0.0254;

void on_control_lost(ArvDevice* /*device*/, gpointer user_data) {
  static_cast<std::atomic<bool>*>(user_data)->store(true);
}

/// Vendor, model and serial number as the camera reports them ("" where it does not).
CameraIdentity read_identity(ArvCamera* cam) {
  GError* error = nullptr;
  CameraIdentity id;
  id.driver = "aravis";
  id.vendor = str_or(arv_camera_get_vendor_name(cam, &error), "");
  g_clear_error(&error);
  id.model = str_or(arv_camera_get_model_name(cam, &error), "");
  g_clear_error(&error);
  id.serial = str_or(arv_camera_get_device_serial_number(cam, &error), "");
  g_clear_error(&error);
  return id;
}

/// The GigE Vision device's IP address as text ("" when it has none).
std::string device_address(ArvDevice* device) {
  std::string text_address;
  GSocketAddress* address = arv_gv_device_get_device_address(ARV_GV_DEVICE(device));
  if (address != nullptr) {
    GInetAddress* inet = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(address));
    gchar* text = g_inet_address_to_string(inet);
    text_address = text != nullptr ? text : "";
    g_free(text);
  }
  return text_address;
}

/// [m] of one Scan3dDistanceUnit; anything unknown is taken as Millimeter.
double distance_unit_m(const std::string& unit) {
  if (unit == "Meter") return kMetre_m;
  if (unit == "Inch") return kInch_m;
  if (unit == "Micrometer") return kMicrometre_m;
  return kMillimetre_m;
}

}  // namespace

/// Connects, checks and publishes the camera's identity, watches its control channel, then
/// configures the camera and reads how it encodes depth and its intrinsics.
Status AravisCamera::do_open() {
  // The device closed last is finalized here, in this thread, long after any emission of its
  // heartbeat thread: it leaves the camera's control before a new device asks for it.
  impl_->closed_device.reset();
  if (Status st = connect_camera(); !st) return st;
  // Identity: as the camera reports it, checked against the configuration, then published.
  ArvCamera* cam = impl_->camera.get();
  CameraIdentity id = read_identity(cam);
  ArvDevice* device = arv_camera_get_device(cam);
  id.address = device_address(device);
  if (Status st = check_identity(id); !st) return st;
  impl_->camera_id = id.id();
  set_identity(id);

  // The heartbeat's "control-lost" signal marks the camera gone (do_alive(), do_grab()).
  impl_->control_lost = false;
  impl_->control_lost_handler =
      g_signal_connect(device, "control-lost", G_CALLBACK(on_control_lost), &impl_->control_lost);

  if (Status st = configure_pixel_format(); !st) return st;
  if (Status st = read_scan3d(); !st) return st;
  if (Status st = read_intrinsics(); !st) return st;
  if (Status st = configure_acquisition(); !st) return st;
  return configure_packet_size();
}

/// Opens the camera by its address, else its serial number, else its user id; all empty: the
/// first camera discovery finds (commissioning with one camera on the link).
Status AravisCamera::connect_camera() {
  GError* error = nullptr;
  const std::string name = !options_.address.empty() ? options_.address
                           : !options_.serial.empty() ? options_.serial
                                                      : options_.user_id;
  impl_->camera.reset(arv_camera_new(name.empty() ? nullptr : name.c_str(), &error));
  if (!impl_->camera) {
    return Error{"aravis: cannot open camera '" + (name.empty() ? std::string("(first found)") : name) +
                 "': " + take(error)};
  }
  if (!arv_camera_is_gv_device(impl_->camera.get())) {
    return Error{"aravis: '" + name + "' is not a GigE Vision camera"};
  }
  return {};
}

/// The camera opened must be the one configured: its serial number, and its DeviceUserID where
/// the camera has that feature.
Status AravisCamera::check_identity(const CameraIdentity& id) const {
  if (!options_.serial.empty() && id.serial != options_.serial) {
    return Error{"aravis: camera at " + id.address + " has serial '" + id.serial +
                 "', configured '" + options_.serial + "'"};
  }
  if (!options_.user_id.empty() && impl_->feature("DeviceUserID")) {
    GError* error = nullptr;
    const std::string user = str_or(arv_camera_get_string(impl_->camera.get(), "DeviceUserID", &error), "");
    g_clear_error(&error);
    if (user != options_.user_id) {
      return Error{"aravis: camera at " + id.address + " has user id '" + user + "', configured '" +
                   options_.user_id + "'"};
    }
  }
  return {};
}

/// Sets the configured PixelFormat and reads back the one the camera delivers.
Status AravisCamera::configure_pixel_format() {
  ArvCamera* cam = impl_->camera.get();
  GError* error = nullptr;
  arv_camera_set_pixel_format_from_string(cam, options_.pixel_format.c_str(), &error);
  if (error != nullptr) {
    return Error{"aravis: camera " + impl_->camera_id + " refuses PixelFormat " +
                 options_.pixel_format + ": " + take(error)};
  }
  impl_->pixel_format = arv_camera_get_pixel_format(cam, &error);
  if (error != nullptr) return Error{"aravis: cannot read PixelFormat: " + take(error)};
  return {};
}

/// The Scan3d description of the depth coordinate: configured for Mono16, else read from the
/// camera's Scan3d features of CoordinateC (SFNC defaults where a feature is missing).
Status AravisCamera::read_scan3d() {
  ArvCamera* cam = impl_->camera.get();
  GError* error = nullptr;
  aravis::Scan3dParams p;
  if (impl_->pixel_format == ARV_PIXEL_FORMAT_MONO_16) {
    p.scale = options_.mono16_scale_m;
    p.unit_m = kMetre_m;  // the configured scale is in metres
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
      p.unit_m = distance_unit_m(unit);
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
  return {};
}

/// Intrinsics: the configuration wins, then the camera's Scan3d features; the image size is the
/// camera's region either way, and configured intrinsics must be for that size.
Status AravisCamera::read_intrinsics() {
  GError* error = nullptr;
  gint x = 0, y = 0, width = 0, height = 0;
  arv_camera_get_region(impl_->camera.get(), &x, &y, &width, &height, &error);
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
  return {};
}

/// Trigger mode: software trigger where configured and the camera has it, else free-running;
/// continuous acquisition either way.
Status AravisCamera::configure_acquisition() {
  ArvCamera* cam = impl_->camera.get();
  GError* error = nullptr;
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
  return {};
}

/// The configured GigE Vision packet size, else the largest the link carries (negotiated).
Status AravisCamera::configure_packet_size() {
  ArvCamera* cam = impl_->camera.get();
  GError* error = nullptr;
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

}  // namespace palletd
