// The health window's means and warnings, and the registers' view of them (health_monitor.hpp).
#include <catch2/catch.hpp>

#include "health_monitor.hpp"

using namespace palletd;

namespace {

FrameHealth frame(double invalid, std::optional<double> noise_ratio = std::nullopt) {
  FrameHealth f;
  f.measured = true;
  f.invalid_fraction = invalid;
  f.flying_fraction = 0.2;
  f.noise_ratio = noise_ratio;
  return f;
}

HealthConfig limits(int window) {
  HealthConfig c;
  c.window_frames = window;
  c.max_invalid_fraction = 0.25;
  c.max_noise_ratio = 2.0;
  return c;
}

}  // namespace

TEST_CASE("health window: a mean beyond its limit warns once half the window is full", "[health]") {
  HealthMonitor monitor(limits(4));
  CHECK(monitor.summary().frames == 0);
  CHECK_FALSE(monitor.summary().invalid_fraction);
  monitor.add(frame(0.9));
  // One bad frame after a start is not a trend yet.
  CHECK(monitor.summary().warnings == 0);
  monitor.add(frame(0.9));
  CellHealth h = monitor.summary();
  CHECK(h.frames == 2);
  CHECK(*h.invalid_fraction == Approx(0.9));
  CHECK((h.warnings & modbus::kHealthInvalid) != 0);
  // Clean frames push the bad ones out of the window.
  for (int i = 0; i < 4; ++i) monitor.add(frame(0.05));
  h = monitor.summary();
  CHECK(h.frames == 4);
  CHECK(*h.invalid_fraction == Approx(0.05));
  CHECK(h.warnings == 0);
  // Frames detect() could not read are not counted.
  monitor.add(FrameHealth{});
  CHECK(monitor.summary().frames == 4);
}

TEST_CASE("health window: a limit of 0 is not checked, a figure no frame has is null", "[health]") {
  HealthMonitor monitor(limits(2));
  for (int i = 0; i < 2; ++i) monitor.add(frame(0.1, 3.0));
  CellHealth h = monitor.summary();
  CHECK((h.warnings & modbus::kHealthNoise) != 0);
  CHECK((h.warnings & modbus::kHealthFlying) == 0);  // max_flying_fraction 0: not checked
  CHECK_FALSE(h.saturated_fraction);
  HealthConfig off = limits(2);
  off.max_noise_ratio = 0.0;
  monitor.set_limits(off);
  CHECK((monitor.summary().warnings & modbus::kHealthNoise) == 0);
}

TEST_CASE("health window: drift beyond max_drift_mm or max_drift_deg warns, and reaches the registers",
          "[health]") {
  HealthMonitor monitor(limits(4));
  monitor.set_drift(DriftReading{true, true, 4.0, 0.1, ""});
  CellHealth h = monitor.summary();
  CHECK((h.warnings & modbus::kHealthDrift) == 0);
  CHECK((h.warnings & modbus::kHealthDriftReference) != 0);
  CHECK((h.warnings & modbus::kHealthDriftMeasured) != 0);
  monitor.set_drift(DriftReading{true, true, 4.0, 0.5, ""});  // turned beyond 0.3 deg
  h = monitor.summary();
  CHECK((h.warnings & modbus::kHealthDrift) != 0);
  monitor.set_drift(DriftReading{true, true, 12.0, 0.0, ""});  // shifted beyond 10 mm
  h = monitor.summary();
  CHECK((h.warnings & modbus::kHealthDrift) != 0);
  const modbus::HealthRecord r = to_health_record(h);
  CHECK(r.drift_shift_mm == 12.0);
  CHECK(r.flags == h.warnings);
  // Not measured once (a forklift hides the cell): no warning, no figures.
  monitor.set_drift(DriftReading{true, false, 0.0, 0.0, "too few fixed points"});
  h = monitor.summary();
  CHECK((h.warnings & (modbus::kHealthDrift | modbus::kHealthDriftMeasured)) == 0);
  CHECK(h.drift_note == "too few fixed points");
  // Not matched frame after frame: the camera no longer sees the cell it was set on.
  for (int i = 1; i < kUnmatchedFramesWarn; ++i) monitor.set_drift(DriftReading{true, false, 0.0, 0.0, "x"});
  h = monitor.summary();
  CHECK((h.warnings & modbus::kHealthDrift) != 0);
  CHECK(h.drift_note.find("in a row") != std::string::npos);
  monitor.set_drift(DriftReading{true, true, 1.0, 0.05, ""});
  CHECK((monitor.summary().warnings & modbus::kHealthDrift) == 0);
  // Without a reference nothing is expected to match.
  for (int i = 0; i < 5; ++i) monitor.set_drift(DriftReading{false, false, 0.0, 0.0, "no reference"});
  CHECK((monitor.summary().warnings & modbus::kHealthDrift) == 0);
}
