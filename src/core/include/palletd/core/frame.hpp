// palletd core: the depth frame as it travels from a camera driver (or a frame file) to detection.
//
// Camera frame convention (shared/spec/frames.md): x right, y down, z forward, metres.
// Pixel (u, v) with depth Z maps to X = (u - cx) Z / fx, Y = (v - cy) Z / fy.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace palletd {

/// Pinhole intrinsics in pixels, with optional OpenCV plumb-bob distortion (k1 k2 p1 p2 k3).
struct Intrinsics {
  int width = 0;   ///< [px]
  int height = 0;  ///< [px]
  double fx = 0.0, fy = 0.0;  ///< focal lengths [px]
  double cx = 0.0, cy = 0.0;  ///< principal point [px]
  std::optional<std::array<double, 5>> distortion;  ///< absent = no distortion

  [[nodiscard]] bool valid() const {
    return width > 0 && height > 0 && fx > 0.0 && fy > 0.0;
  }
};

/// One depth frame with its metadata. A value type: move it, do not share it mutably.
///
/// Depth is stored as the camera (or PNG) delivers it: 16-bit units of `depth_scale_m` metres,
/// Z along the optical axis, 0 = no measurement. Drivers that deliver float depth or XYZ
/// quantise to 0.1 mm (depth_scale_m = 1e-4), which covers 6.5 m.
struct Frame {
  Intrinsics intrinsics;
  std::vector<std::uint16_t> depth;  ///< row-major, width*height, units of depth_scale_m
  double depth_scale_m = 0.001;      ///< [m per unit]
  std::vector<std::uint16_t> intensity;  ///< row-major, width*height, empty = none
  int intensity_bits = 0;                ///< 8 or 16 when intensity is present, else 0
  std::optional<Eigen::Isometry3d> T_base_camera;  ///< camera -> robot base, when calibrated
  std::string camera_id;       ///< "model-serial"
  std::int64_t timestamp_ns = 0;
  std::uint64_t sequence = 0;  ///< driver frame counter

  [[nodiscard]] std::size_t pixel_count() const {
    return static_cast<std::size_t>(intrinsics.width) * static_cast<std::size_t>(intrinsics.height);
  }
  [[nodiscard]] bool has_intensity() const { return !intensity.empty(); }
  /// Depth of pixel index i in metres; NaN when there is no measurement.
  [[nodiscard]] float depth_m(std::size_t i) const;
};

/// Unit-depth viewing ray per pixel: point = ray * Z. Undistorted when the intrinsics carry
/// distortion. Computed once per set of intrinsics and reused frame after frame.
class RayTable {
 public:
  RayTable() = default;
  explicit RayTable(const Intrinsics& intrinsics);
  [[nodiscard]] const Intrinsics& intrinsics() const { return intrinsics_; }
  /// Normalised image coordinates (x/z, y/z) of pixel index i.
  [[nodiscard]] const Eigen::Vector2f& ray(std::size_t i) const { return rays_[i]; }
  [[nodiscard]] bool matches(const Intrinsics& other) const;
  [[nodiscard]] bool empty() const { return rays_.empty(); }

 private:
  Intrinsics intrinsics_;
  std::vector<Eigen::Vector2f> rays_;
};

/// Organized point cloud in the camera frame [m]: one point per pixel, NaN where depth is 0.
struct OrganizedCloud {
  int width = 0;
  int height = 0;
  std::vector<Eigen::Vector3f> points;

  [[nodiscard]] const Eigen::Vector3f& at(int u, int v) const {
    return points[static_cast<std::size_t>(v) * static_cast<std::size_t>(width) +
                  static_cast<std::size_t>(u)];
  }
};

/// Fills `cloud` from `frame` (reusing its storage). `rays` must match the frame's intrinsics.
void to_organized_cloud(const Frame& frame, const RayTable& rays, OrganizedCloud& cloud);

}  // namespace palletd
