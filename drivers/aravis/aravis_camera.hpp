// The Aravis driver: GigE Vision ToF cameras (Basler blaze, Lucid Helios2 and similar).
// Private header: only drivers/ sees it, and it names no Aravis type (those stay in
// aravis_camera_impl.hpp and the .cpp files).
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "palletd/drivers/camera.hpp"
#include "palletd/drivers/camera_config.hpp"

namespace palletd {

/// One GigE Vision camera through Aravis. All GObjects are owned by RAII wrappers (Impl, in
/// aravis_camera_impl.hpp, which only the driver's .cpp files include).
class AravisCamera final : public Camera {
 public:
  explicit AravisCamera(AravisOptions options);
  ~AravisCamera() override;

  [[nodiscard]] bool trigger_mode() const override { return trigger_mode_; }

 protected:
  Status do_open() override;
  Status do_start() override;
  Status do_stop() override;
  void do_close() override;
  Expected<Frame> do_grab(std::chrono::milliseconds timeout) override;
  Status do_software_trigger() override;
  [[nodiscard]] bool do_alive() const override;

 private:
  struct Impl;
  void update_stream_counters();
  Status probe_control();
  Error no_frame(std::chrono::milliseconds timeout);  ///< do_grab() without a buffer in time

  // do_open() in phases (aravis_camera_open.cpp), in the order it calls them.
  Status connect_camera();
  Status check_identity(const CameraIdentity& id) const;
  Status configure_pixel_format();
  Status read_scan3d();
  Status read_intrinsics();
  Status configure_acquisition();
  Status configure_packet_size();

  AravisOptions options_;
  std::unique_ptr<Impl> impl_;
  std::atomic<bool> trigger_mode_{false};
  int timeouts_in_row_ = 0;
  std::uint64_t sequence_ = 0;
};

}  // namespace palletd
