// Rolling window of the cell's health and its warnings (health_monitor.hpp).
#include "health_monitor.hpp"

#include <algorithm>
#include <optional>

namespace palletd {

namespace {

/// Mean of a figure over the frames that have it; null when none does.
template <typename Get>
std::optional<double> mean_of(const std::deque<FrameHealth>& window, Get get) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const FrameHealth& f : window) {
    if (const std::optional<double> v = get(f)) {
      sum += *v;
      ++n;
    }
  }
  if (n == 0) return std::nullopt;
  return sum / static_cast<double>(n);
}

bool beyond(const std::optional<double>& mean, double limit) { return limit > 0.0 && mean && *mean > limit; }

}  // namespace

void HealthMonitor::set_limits(const HealthConfig& limits) {
  limits_ = limits;
  while (window_.size() > static_cast<std::size_t>(std::max(1, limits_.window_frames))) window_.pop_front();
}

void HealthMonitor::add(const FrameHealth& frame) {
  if (!frame.measured) return;
  window_.push_back(frame);
  while (window_.size() > static_cast<std::size_t>(std::max(1, limits_.window_frames))) window_.pop_front();
}

void HealthMonitor::set_drift(DriftReading drift) {
  unmatched_in_row_ = drift.reference && !drift.measured ? unmatched_in_row_ + 1 : 0;
  drift_ = std::move(drift);
}

CellHealth HealthMonitor::summary() const {
  CellHealth h;
  h.frames = window_.size();
  h.invalid_fraction =
      mean_of(window_, [](const FrameHealth& f) { return std::optional<double>(f.invalid_fraction); });
  h.flying_fraction = mean_of(window_, [](const FrameHealth& f) { return f.flying_fraction; });
  h.saturated_fraction = mean_of(window_, [](const FrameHealth& f) { return f.saturated_fraction; });
  h.plane_noise_mm = mean_of(window_, [](const FrameHealth& f) { return f.plane_noise_mm; });
  h.noise_ratio = mean_of(window_, [](const FrameHealth& f) { return f.noise_ratio; });
  const bool settled = 2 * h.frames >= static_cast<std::size_t>(std::max(1, limits_.window_frames));
  if (settled) {
    if (beyond(h.invalid_fraction, limits_.max_invalid_fraction)) h.warnings |= modbus::kHealthInvalid;
    if (beyond(h.flying_fraction, limits_.max_flying_fraction)) h.warnings |= modbus::kHealthFlying;
    if (beyond(h.saturated_fraction, limits_.max_saturated_fraction)) h.warnings |= modbus::kHealthSaturated;
    if (beyond(h.noise_ratio, limits_.max_noise_ratio)) h.warnings |= modbus::kHealthNoise;
  }
  h.drift_reference = drift_.reference;
  h.drift_measured = drift_.measured;
  h.drift_shift_mm = drift_.shift_mm;
  h.drift_angle_deg = drift_.angle_deg;
  h.drift_note = drift_.note;
  if (drift_.reference) h.warnings |= modbus::kHealthDriftReference;
  if (drift_.measured) {
    h.warnings |= modbus::kHealthDriftMeasured;
    if (drift_.shift_mm > limits_.max_drift_mm || drift_.angle_deg > limits_.max_drift_deg)
      h.warnings |= modbus::kHealthDrift;
  } else if (unmatched_in_row_ >= kUnmatchedFramesWarn) {
    h.warnings |= modbus::kHealthDrift;
    h.drift_note = std::to_string(unmatched_in_row_) +
                   " frames in a row do not match the drift reference: " + drift_.note;
  }
  return h;
}

modbus::HealthRecord to_health_record(const CellHealth& health) {
  modbus::HealthRecord r;
  r.flags = health.warnings;
  r.frames = static_cast<std::uint16_t>(std::min<std::size_t>(health.frames, 65535));
  r.invalid_fraction = health.invalid_fraction.value_or(0.0);
  r.flying_fraction = health.flying_fraction.value_or(0.0);
  r.saturated_fraction = health.saturated_fraction.value_or(0.0);
  r.noise_ratio = health.noise_ratio.value_or(0.0);
  r.drift_shift_mm = health.drift_measured ? health.drift_shift_mm : 0.0;
  r.drift_angle_deg = health.drift_measured ? health.drift_angle_deg : 0.0;
  return r;
}

}  // namespace palletd
