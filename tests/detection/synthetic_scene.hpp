// Small analytic scenes for the layer tests (and the layer benchmark when no simulator is used):
// yawed cuboids on a floor, a pinhole camera looking down with tilt, one ray per pixel centre,
// Gaussian depth noise, dropouts, flying pixels at depth edges. Seeded: same input, same frame.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd::testing {

/// A cuboid in the world frame (z up, floor at z = 0) [m].
struct SynthBox {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double yaw_rad = 0.0;
  double long_m = 0.315, short_m = 0.232;
  double bottom_z_m = 0.0, top_z_m = 0.2;
  [[nodiscard]] std::vector<Eigen::Vector2d> corners() const;  ///< top face, CCW
};

struct SynthScene {
  std::vector<SynthBox> boxes;
  std::vector<std::size_t> top;  ///< indices of the top layer's boxes
  double top_z_m = 0.0;
  bool floor = true;
};

struct SynthCamera {
  int width = 640, height = 480;
  double fx = 570.0, fy = 570.0;
  double distance_m = 1.8;   ///< from the camera to the look-at point
  double tilt_deg = 0.0;     ///< angle between the optical axis and straight down
  double tilt_azimuth_deg = 0.0;
  double roll_deg = 0.0;     ///< image rotation about the optical axis
  Eigen::Vector3d look_at = Eigen::Vector3d::Zero();
};

struct SynthNoise {
  double sigma_m = 0.0015;   ///< Gaussian depth noise
  double dropout = 0.02;     ///< share of random invalid pixels
  double flying = 0.3;       ///< probability of a mixed pixel at a depth edge
  std::uint32_t seed = 7;
};

struct SynthFrame {
  Frame frame;
  OrganizedCloud cloud;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  Plane top_plane_camera;  ///< truth
};

SynthFrame render_synthetic(const SynthScene& scene, const SynthCamera& camera, const SynthNoise& noise);

/// One box (long side along x turned by yaw_rad) standing on the floor, centred on the origin,
/// its top at top_z_m; the scene's only top-layer box.
SynthScene single_box(double long_m, double short_m, double yaw_rad, double top_z_m);

/// The default camera looking at (0, 0, look_at_z_m), tilted by tilt_deg toward tilt_azimuth_deg.
SynthCamera camera_looking_at(double look_at_z_m, double tilt_deg = 0.0, double tilt_azimuth_deg = 0.0);

/// A full layer of nx x ny boxes (long side along x) at top_z on a full lower layer, with gaps.
SynthScene grid_layer(int nx, int ny, double gap_m, double top_z_m, bool with_lower_layer);

/// Truth top faces of the top layer in the layer frame of `result` (z dropped) [m].
std::vector<std::vector<Eigen::Vector2d>> truth_in_layer(const SynthScene& scene, const SynthFrame& frame,
                                                         const Eigen::Isometry3d& T_camera_layer);

/// IoU of the union of `polygons` (with holes) and the union of the convex quads `truth`,
/// rasterised at `cell_m`.
double polygon_iou(const std::vector<PolygonWithHoles>& polygons,
                   const std::vector<std::vector<Eigen::Vector2d>>& truth, double cell_m = 0.001);

/// Refreshes frame.cloud from frame.frame (after editing depths).
void rebuild_cloud(SynthFrame& frame);

}  // namespace palletd::testing
