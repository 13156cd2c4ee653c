// The cell's health over a rolling window of triggered frames, and the camera's drift (private to
// the service; the pipeline thread owns one). Pure: no clock, no I/O.
#pragma once

#include <cstddef>
#include <deque>
#include <string>

#include "palletd/config/config.hpp"
#include "palletd/detection/health.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/status/snapshot.hpp"

namespace palletd {

/// The camera's pose against its drift reference for one frame, as the monitor keeps it.
struct DriftReading {
  bool reference = false;  ///< a reference is loaded
  bool measured = false;   ///< this frame was compared with it
  double shift_mm = 0.0;
  double angle_deg = 0.0;
  std::string note;  ///< why not measured, or the motions the reference cannot see
};

class HealthMonitor {
 public:
  explicit HealthMonitor(const HealthConfig& limits) : limits_(limits) {}

  /// New limits (reload); the window is kept, shortened when the new one is shorter.
  void set_limits(const HealthConfig& limits);
  /// One triggered frame's figures (frames detect() could not read are not counted).
  void add(const FrameHealth& frame);
  /// The last frame's drift. A reference that cannot be matched for kUnmatchedFramesWarn frames
  /// in a row warns too: a camera knocked far enough no longer sees the cell it was set on.
  void set_drift(DriftReading drift);

  /// Window means, warnings and drift. A limit of 0 is not checked; a mean is compared only once
  /// half the window is full, so one bad frame after a start does not warn.
  [[nodiscard]] CellHealth summary() const;

 private:
  HealthConfig limits_;
  std::deque<FrameHealth> window_;
  DriftReading drift_;
  int unmatched_in_row_ = 0;  ///< frames in a row a loaded reference could not be compared with
};

/// Frames in a row without a drift measurement (reference loaded) that raise DriftWarning.
inline constexpr int kUnmatchedFramesWarn = 3;

/// The registers' view of a summary (146..155).
modbus::HealthRecord to_health_record(const CellHealth& health);

}  // namespace palletd
