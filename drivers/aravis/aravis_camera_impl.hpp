// Private to the Aravis driver: the GObject helpers and AravisCamera::Impl (the camera's Aravis
// handles and what do_open() read from the camera), shared by aravis_camera.cpp (streaming) and
// aravis_camera_open.cpp (opening and configuring). Names Aravis types: include it from those two
// files only (aravis_camera.hpp stays free of them).
#pragma once

#include <arv.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "aravis/aravis_camera.hpp"
#include "aravis/depth_convert.hpp"

namespace palletd {

namespace aravis {

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
inline std::string take(GError*& error) {
  if (error == nullptr) return {};
  std::string message = error->message != nullptr ? error->message : "unknown error";
  g_clear_error(&error);
  return message;
}

inline std::string str_or(const char* s, const char* fallback) { return s != nullptr ? s : fallback; }

}  // namespace aravis

struct AravisCamera::Impl {
  aravis::GPtr<ArvCamera> camera;
  aravis::GPtr<ArvStream> stream;
  /// The device of the camera last closed, held to the next open (or the destructor): its
  /// heartbeat thread emits "control-lost" holding a reference on it, and the last reference
  /// dropped while that emission runs would finalize the device in that thread, which then joins
  /// itself (GLib aborts the process).
  aravis::GPtr<ArvDevice> closed_device;
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

}  // namespace palletd
