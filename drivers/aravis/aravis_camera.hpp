// The Aravis driver: GigE Vision ToF cameras (Basler blaze, Lucid Helios2 and similar).
// Private header: only drivers/ sees it, and it names no Aravis type (those stay in the .cpp).
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "palletd/drivers/camera.hpp"
#include "palletd/drivers/camera_config.hpp"

namespace palletd {

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
