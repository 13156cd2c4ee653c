// palletd detection: a region of interest suggested from one frame of the cell (`palletctl roi`).
// A pure function like detect(): frame and calibration in, suggestion out; no files, no logging.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/detection.hpp"

namespace palletd {

struct RoiSuggestionOptions {
  /// The frame the region is wanted in. kBase needs a calibration; without one the suggestion
  /// falls back to kCamera and says so in its message.
  RegionOfInterest::Frame frame = RegionOfInterest::Frame::kBase;
  double margin_m = 0.1;  ///< the footprint's bounding box grown by this on every side [m]
  double above_m = 0.3;   ///< z max = the load's top + this [m]
  /// When given: z max = the floor + this [m] (the full load, higher than the current top).
  std::optional<double> max_load_height_m;
  double floor_clearance_m = 0.1;   ///< z min = the floor + this [m]; what is below stays visible
  double load_min_height_m = 0.05;  ///< points this far above the floor stand on it [m]
  double cell_m = 0.01;             ///< occupancy grid cell in the horizontal plane [m]
  /// Points higher than the stack's top (found near the optical axis) by more than this belong to
  /// another object, e.g. a cabinet right next to the pallet [m].
  double tall_step_m = 0.4;
  double top_search_radius_m = 0.4;   ///< the stack's top is looked for this close to the seed [m]
  double min_object_area_m2 = 0.005;  ///< smaller blobs beside the pallet are noise, not objects
};

struct RoiSuggestion {
  bool ok = false;
  RegionOfInterest roi;  ///< the suggested region (frame: base, or camera as a fallback)
  /// The plan frame the footprint was found in: the base frame, or without a calibration the
  /// camera frame turned so that z points up from the floor (its x-y is the floor plane).
  Eigen::Isometry3d T_plan_camera = Eigen::Isometry3d::Identity();
  Ring2d footprint_m;  ///< the footprint's outline in the plan frame's x-y [m]
  Eigen::Vector2d footprint_size_m = Eigen::Vector2d::Zero();  ///< its bounding box, x by y [m]
  double floor_z_m = 0.0;                                      ///< the floor level in the plan frame [m]
  double load_top_z_m = 0.0;                                   ///< the load's top in the plan frame [m]
  int excluded_objects = 0;      ///< objects standing on the floor that are not the pallet
  bool camera_fallback = false;  ///< base frame asked for, no calibration: camera frame given
  std::string message;           ///< one line for the user: what was found, or why nothing was
};

/// Suggests the work volume around the pallet seen in `frame`.
///
/// The rule: the frame's points are taken to the base frame (without `T_base_camera`: a frame
/// whose up is the normal of the floor plane fitted in the camera frame). The floor is the lowest
/// large level of the height histogram; whatever stands more than load_min_height_m above it goes
/// into a 2-D occupancy grid of the x-y plane. The pallet is the connected blob under the optical
/// axis (where the axis meets the floor), or the blob nearest to that point when the axis misses
/// every blob. The stack's top is the largest level of that blob near that point; points more than
/// tall_step_m above it are left out of the grid and the blob is found again, so that a cabinet
/// touching the pallet does not join it. The region is the blob's bounding box grown by
/// margin_m, from the floor + floor_clearance_m up to the top + above_m (or the floor +
/// max_load_height_m). `ok` is false, with the reason in `message`, when no floor or nothing
/// standing on it is seen.
RoiSuggestion suggest_region_of_interest(const Frame& frame,
                                         const std::optional<Eigen::Isometry3d>& T_base_camera,
                                         const RoiSuggestionOptions& options = {});

}  // namespace palletd
