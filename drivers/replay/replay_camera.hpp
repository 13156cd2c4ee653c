// The replay driver: a folder of frames (shared/spec/frames.md) played back in name order.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "palletd/drivers/camera.hpp"
#include "palletd/drivers/camera_config.hpp"

namespace palletd {

/// Plays a folder of frames (and organized *.pcd / *.ply clouds, see cloud_frame.hpp) in name
/// order. A bad frame file fails that grab (the error names the file) and the next grab goes
/// on with the next frame; a folder that disappears faults the camera.
/// At a set rate, frames are paced at rate_hz and never dropped (a late caller gets the next
/// frame at once). In trigger mode, each software_trigger() releases one frame.
class ReplayCamera final : public Camera {
 public:
  explicit ReplayCamera(ReplayOptions options);
  ~ReplayCamera() override { close(); }

  [[nodiscard]] bool trigger_mode() const override { return options_.rate_hz <= 0.0; }
  /// Number of frames found at open() (or at the last wrap-around).
  [[nodiscard]] std::size_t frame_count() const { return stems_.size(); }

 protected:
  Status do_open() override;
  Status do_start() override;
  Status do_stop() override;
  void do_close() override;
  Expected<Frame> do_grab(std::chrono::milliseconds timeout) override;
  Status do_software_trigger() override;

 private:
  Status list_stems();
  bool directory_present() const;

  ReplayOptions options_;
  std::vector<std::string> stems_;
  std::size_t next_index_ = 0;
  std::uint64_t sequence_ = 0;
  std::chrono::steady_clock::time_point next_due_;
  std::mutex trigger_mutex_;
  std::condition_variable trigger_cv_;
  int pending_triggers_ = 0;
};

}  // namespace palletd
