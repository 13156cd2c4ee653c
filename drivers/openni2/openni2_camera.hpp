// The OpenNI2 driver: structured-light and ToF devices with an OpenNI2 driver, and .oni
// recordings. Private header: only drivers/ sees it, and it names no OpenNI type (those stay in
// the .cpp).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "palletd/drivers/camera.hpp"
#include "palletd/drivers/camera_config.hpp"

namespace palletd {

/// Whether `uri` names an .oni recording (by its extension, case-insensitive).
bool is_oni_path(const std::string& uri);

/// Pinhole intrinsics from a field of view: fx = (w/2) / tan(hfov/2), fy likewise, principal
/// point at the centre of the pixel grid ((w-1)/2, (h-1)/2; OpenNI's own CoordinateConverter
/// uses w/2, half a pixel off). Invalid (fx = 0) when a field of view is not in (0, pi).
Intrinsics intrinsics_from_fov(int width, int height, double hfov_rad, double vfov_rad);

/// One OpenNI2 device or .oni file. The OpenNI2 runtime is initialised on open() (reference
/// counted across cameras) and shut down when the last camera closes; all OpenNI handles are
/// owned by RAII wrappers in the .cpp. Frames free-run (no trigger mode).
///
/// Depth and IR: OpenNI's frame callbacks (its own per-stream threads) put every frame they see
/// into two small rings (frame_pairing.hpp); grab() takes the newest depth frame (older unread
/// ones count as drops) and pairs it with the IR frame nearest its device timestamp, within half a
/// frame period, waiting up to max(3 frame periods, 100 ms) within the grab's timeout for one
/// still to come. So a consumer slower than the frame rate still gets each depth frame's own IR
/// image. OpenNI keeps only one unread frame per stream, so a callback that runs late can miss a
/// frame: when a depth frame's partner is lost that way and a newer depth frame comes within the
/// wait, the newer one is taken (the skipped one counts as a drop); otherwise the depth frame is
/// delivered without intensity and counted (frames_without_ir()). The callbacks are removed, and
/// the held frames released, before the streams stop or go away (stop(), close(), rewinding).
///
/// .oni playback runs at the recorded speed; at the end of the file the camera reopens the file
/// (PlaybackControl::seek() crashes in Debian's OpenNI2 2.2) when `loop` is set, else grab()
/// reports the end of the recording. Speed -1 (manual stepping) is never used: with
/// waitForAnyStream it hangs in OpenNI2 2.2. Closing or reopening a file takes 100 ms more: the
/// teardown waits for OniFile's player thread (see Session::~Session in the .cpp).
class OpenNI2Camera final : public Camera {
 public:
  explicit OpenNI2Camera(OpenNI2Options options);
  ~OpenNI2Camera() override;

  [[nodiscard]] bool trigger_mode() const override { return false; }
  /// Frames in the open .oni file (0 for a live device or when closed).
  [[nodiscard]] int recording_frame_count() const;
  /// Times the .oni file was reopened to start again.
  [[nodiscard]] std::uint64_t rewinds() const { return rewinds_; }
  /// Depth frames delivered without intensity although the IR stream runs (no IR frame within
  /// half a frame period came in time). Any thread.
  [[nodiscard]] std::uint64_t frames_without_ir() const { return without_ir_.load(); }

 protected:
  Status do_open() override;
  Status do_start() override;
  Status do_stop() override;
  void do_close() override;
  Expected<Frame> do_grab(std::chrono::milliseconds timeout) override;

 private:
  struct Impl;
  Status open_device();
  Status start_streams();
  Expected<Frame> rewind_and_grab(std::chrono::milliseconds timeout);
  Error no_depth(std::chrono::milliseconds timeout);  ///< do_grab() without a depth frame in time

  OpenNI2Options options_;
  std::unique_ptr<Impl> impl_;
  int timeouts_in_row_ = 0;
  std::uint64_t sequence_ = 0;
  std::uint64_t rewinds_ = 0;
  std::atomic<std::uint64_t> without_ir_{0};
};

}  // namespace palletd
