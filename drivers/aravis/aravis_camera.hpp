// The Aravis driver: GigE Vision ToF cameras (Basler blaze, Lucid Helios2 and similar).
// Private header: only drivers/ sees it, and it names no Aravis type (those stay in the .cpp).
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "palletd/camera.hpp"

namespace palletd {

struct AravisOptions {
  std::string address;   ///< IP address: opened directly, no broadcast discovery
  std::string serial;    ///< or serial number (discovery); checked against the camera if both
  std::string user_id;   ///< or DeviceUserID (discovery)
  std::string pixel_format = "Coord3D_C16";  ///< Coord3D_C16 | Coord3D_ABC32f | Mono16
  double mono16_scale_m = 0.001;  ///< [m per unit] for Mono16
  int packet_size = 0;            ///< [bytes]; 0 = negotiate (auto packet size)
  bool packet_resend = true;
  int buffer_count = 8;           ///< stream buffer pool
  bool software_trigger = true;   ///< trigger mode with TriggerSoftware when the camera has it
  /// Free-running: this many timeouts in a row mean the stream stopped (camera faulted).
  int timeouts_before_fault = 2;
  std::optional<Intrinsics> intrinsics_override;
};

/// One GigE Vision camera through Aravis. All GObjects are owned by RAII wrappers in the .cpp.
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

  AravisOptions options_;
  std::unique_ptr<Impl> impl_;
  std::atomic<bool> trigger_mode_{false};
  int timeouts_in_row_ = 0;
  std::uint64_t sequence_ = 0;
};

}  // namespace palletd
