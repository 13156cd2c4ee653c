// Helpers for "a frame through each driver gives the same detection as the same frame through
// replay": detect() with the truth file's recipe, and a box-by-box comparison.
#pragma once

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"
#include "palletd/frames/frame_io.hpp"

namespace palletd::test {

/// Whole-image equality without Catch printing a million pixels on failure.
inline bool same_pixels(const std::vector<std::uint16_t>& a, const std::vector<std::uint16_t>& b) { return a == b; }

/// The recipe of a bundled frame's truth file as detect() takes it.
inline std::vector<BoxFormat> recipe_formats(const std::string& stem) {
  std::vector<BoxFormat> formats;
  auto truth = read_truth(stem);
  REQUIRE(truth.ok());
  for (std::size_t i = 0; i < truth->recipe_mm.size(); ++i) {
    const auto& mm = truth->recipe_mm[i];
    formats.push_back(BoxFormat{mm[0] / 1000.0, mm[1] / 1000.0, i < truth->recipe.size() ? truth->recipe[i] : ""});
  }
  return formats;
}

/// How far two detections of the same scene are apart (max over matched boxes).
struct DetectionDiff {
  bool same_status = false;
  bool same_count = false;
  bool same_formats = false;
  double center_m = 0.0;     ///< largest centre distance [m]
  double axis_deg = 0.0;     ///< largest angle between long axes (sign-free) [deg]
  double normal_deg = 0.0;   ///< largest angle between normals [deg]
  double size_m = 0.0;       ///< largest size difference [m]
};

/// Pairs each box of `a` with the nearest box of `b` (both in pick order are not required).
inline DetectionDiff compare_detections(const Detection& a, const Detection& b) {
  DetectionDiff d;
  d.same_status = a.status == b.status;
  d.same_count = a.boxes.size() == b.boxes.size();
  d.same_formats = d.same_count;
  constexpr double kRadToDeg = 57.29577951308232;
  for (const DetectedBox& x : a.boxes) {
    const DetectedBox* best = nullptr;
    for (const DetectedBox& y : b.boxes) {
      if (best == nullptr || (y.center - x.center).norm() < (best->center - x.center).norm()) best = &y;
    }
    if (best == nullptr) break;
    d.same_formats = d.same_formats && best->format == x.format;
    d.center_m = std::max(d.center_m, (best->center - x.center).norm());
    const double c_axis = std::min(1.0, std::abs(best->long_axis.normalized().dot(x.long_axis.normalized())));
    d.axis_deg = std::max(d.axis_deg, std::acos(c_axis) * kRadToDeg);
    const double c_n = std::clamp(best->normal.normalized().dot(x.normal.normalized()), -1.0, 1.0);
    d.normal_deg = std::max(d.normal_deg, std::acos(c_n) * kRadToDeg);
    d.size_m = std::max({d.size_m, std::abs(best->long_m - x.long_m), std::abs(best->short_m - x.short_m)});
  }
  return d;
}

/// Asserts that two detections agree: same status, boxes and formats; poses within the limits.
inline void require_same_detection(const Detection& through_driver, const Detection& through_replay,
                                   double center_tol_m, double angle_tol_deg) {
  const DetectionDiff d = compare_detections(through_driver, through_replay);
  INFO("boxes " << through_driver.boxes.size() << " vs " << through_replay.boxes.size() << "; centre "
                << d.center_m * 1000.0 << " mm, axis " << d.axis_deg << " deg, normal " << d.normal_deg
                << " deg, size " << d.size_m * 1000.0 << " mm");
  REQUIRE(through_replay.status == DetectionStatus::kOk);
  REQUIRE(!through_replay.boxes.empty());
  CHECK(d.same_status);
  REQUIRE(d.same_count);
  CHECK(d.same_formats);
  CHECK(d.center_m <= center_tol_m);
  CHECK(d.axis_deg <= angle_tol_deg);
  CHECK(d.normal_deg <= angle_tol_deg);
  CHECK(d.size_m <= center_tol_m);
}

}  // namespace palletd::test
