// palletd detection, first half (paper Section III): top plane, layer points, border,
// components and holes, crust contour. Every stage is a function of values in and values out.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "palletd/frame.hpp"
#include "palletd/geometry.hpp"

namespace palletd {

enum class DetectionStatus { ok, no_plane, no_layer, no_layout, bad_frame };
/// "ok", "no_plane", "no_layer", "no_layout", "bad_frame" (the words of shared/spec/detections.md).
const char* to_string(DetectionStatus status);

/// Top plane search (stage 1).
struct PlaneParams {
  double max_tilt_deg = 35.0;          ///< planes whose normal is further than this from the view axis are ignored
  double ransac_distance_m = 0.008;    ///< RANSAC inlier band [m]
  int ransac_max_iterations = 300;
  double min_plane_area_m2 = 0.02;     ///< a plane smaller than this is no layer [m^2]
  std::uint32_t seed = 12345;          ///< RANSAC is seeded: same frame, same result
};

/// Layer points, mask, components (stages 2-4).
struct LayerParams {
  double passthrough_tolerance_m = 0.0;  ///< |z| band around the plane [m]; 0 = derived from noise
  double min_component_box_fraction = 0.5;  ///< components smaller than this share of the smallest box are dropped
};

/// Crust contour and polygon simplification (stage 5).
struct ContourParams {
  double d_max_m = 0.0;                ///< Delaunay edges longer than this are pruned [m]; 0 = from pixel pitch
  double simplify_tolerance_m = 0.006; ///< ring simplification tolerance [m]
};

/// Per-stage diagnostics of the layer extraction.
struct LayerDiagnostics {
  std::size_t valid_points = 0;
  std::size_t plane_inliers = 0;
  std::size_t layer_points = 0;
  std::size_t border_points = 0;
  bool touches_image_border = false;
  double t_plane_ms = 0.0, t_layer_ms = 0.0, t_contour_ms = 0.0;
};

/// Result of the first half of the pipeline.
struct LayerResult {
  DetectionStatus status = DetectionStatus::no_plane;
  std::string reason;                 ///< a sentence when status != ok
  Plane plane_camera;                 ///< top plane in the camera frame
  Eigen::Isometry3d T_camera_layer = Eigen::Isometry3d::Identity();  ///< layer -> camera
  std::vector<PolygonWithHoles> polygons;  ///< one per component, layer frame [m]
  std::vector<Eigen::Vector2f> points_2d;  ///< layer points in the layer frame [m]
  std::vector<std::int32_t> point_pixels;  ///< pixel index of each entry of points_2d
  LayerDiagnostics diagnostics;
};

}  // namespace palletd
