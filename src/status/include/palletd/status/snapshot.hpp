// palletd status: what the service publishes and the status page reads: the last result as an
// immutable snapshot, and the service's live figures. Value types only.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/pick_check.hpp"
#include "palletd/modbus/register_map.hpp"

namespace palletd {

/// One finished trigger, immutable once published.
struct ResultSnapshot {
  std::uint64_t trigger_seq = 0;
  std::uint16_t request_id = 0;
  std::uint16_t recipe = 0;
  modbus::ErrorCode error = modbus::ErrorCode::kNone;
  std::string error_text;  ///< "" when the detection ran; else why it did not
  Detection detection;  ///< after a pick check: the checked layout brought up to date
  /// The result answers a PickCheck: what the check found (its boxes index the checked result's).
  std::optional<PickCheck> check;
  std::shared_ptr<const Frame> frame;  ///< the frame the result was computed from (may be null)
  double latency_ms = 0.0;             ///< trigger edge to result published [ms]
  std::chrono::system_clock::time_point time;
};

/// The cell's health over the last triggered frames (`health` section) and the camera's drift
/// against its reference. Means are null until a frame measured them.
struct CellHealth {
  std::size_t frames = 0;  ///< frames in the window
  std::optional<double> invalid_fraction;    ///< mean share of pixels without depth
  std::optional<double> flying_fraction;     ///< mean share of mixed pixels at the layer's edges
  std::optional<double> saturated_fraction;  ///< mean share of saturated pixels
  std::optional<double> plane_noise_mm;      ///< mean layer plane noise [mm]
  std::optional<double> noise_ratio;         ///< mean plane noise over the noise model's
  std::uint16_t warnings = 0;                ///< modbus::kHealth* bits (register 146)
  bool drift_reference = false;              ///< a drift reference is loaded
  bool drift_measured = false;               ///< the last frame was compared with it
  double drift_shift_mm = 0.0;               ///< camera shift against the reference [mm]
  double drift_angle_deg = 0.0;              ///< camera turn against the reference [deg]
  std::string drift_note;                    ///< why drift is not measured, or what it cannot see
};

/// Live figures of the service, for the watchdog, sd_notify STATUS= and the status page.
struct ServiceHealth {
  bool threads_alive = false;  ///< every thread looped within the last few seconds
  bool camera_ok = false;
  std::string camera_state;
  std::string camera_id;
  std::uint64_t triggers = 0;
  std::uint64_t results = 0;
  std::uint64_t failures = 0;
  std::uint64_t frames = 0;
  std::uint64_t reconnects = 0;
  std::uint16_t modbus_port = 0;
  std::size_t modbus_connections = 0;
  std::uint64_t camera_restarts = 0;     ///< trigger-mode camera restarted after timeouts in a row
  std::uint64_t incomplete_frames = 0;   ///< frames the driver refused (missing packets, wrong size/format)
  std::uint64_t grab_timeouts = 0;       ///< grabs that ended without a frame in time
  std::uint64_t dropped_frames = 0;      ///< frames the camera sent that were lost (no buffer, overrun)
  std::uint64_t camera_losses = 0;       ///< times the camera was found gone (faulted)
  std::uint64_t resent_packets = 0;      ///< GigE Vision packets resent on request
  std::uint64_t recordings = 0;          ///< frames recorded since start
  std::uint64_t recording_failures = 0;  ///< recordings that failed (disk full, read-only, ...)
  std::string last_recording_error;      ///< "" when the last recording succeeded
  bool shadow_enabled = false;              ///< a shadow configuration runs (`shadow_config`)
  std::uint64_t shadow_runs = 0;            ///< frames the shadow configuration detected
  std::uint64_t shadow_disagreements = 0;   ///< of those, results that differ from the live one
  std::uint64_t shadow_skipped = 0;         ///< frames not run (shadow busy, recipe missing)
  std::string last_shadow_difference;       ///< "trigger 12: boxes 12 -> 11"; "" before the first
  CellHealth cell_health;                   ///< health window and drift (registers 146..155)
  /// The detection run at start-up on the camera's first frame (result discarded) so that the
  /// PLC's first trigger does not pay the process's first-use allocations [ms]; -1 before it ran
  /// or when no frame came in time.
  double warm_up_ms = -1.0;
};

}  // namespace palletd
