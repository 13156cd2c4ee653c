// palletd core: geometry value types shared by detection, I/O and the service.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace palletd {

/// Plane n . p + d = 0 with |n| = 1 and n pointing toward the camera side.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double d = 0.0;  ///< [m]

  [[nodiscard]] double signed_distance(const Eigen::Vector3d& p) const { return normal.dot(p) + d; }
};

/// A closed ring of 2D vertices [m], not repeating the first vertex at the end.
using Ring2d = std::vector<Eigen::Vector2d>;

/// A polygon with holes in the layer plane [m]: outer ring counter-clockwise, holes clockwise.
struct PolygonWithHoles {
  Ring2d outer;
  std::vector<Ring2d> holes;
};

/// Signed area of a ring [m^2] (positive when counter-clockwise).
double signed_area(const Ring2d& ring);
/// Area of a polygon with holes [m^2].
double area(const PolygonWithHoles& polygon);

/// A box format: the top face's long and short side [m].
struct BoxFormat {
  double long_m = 0.0;
  double short_m = 0.0;
  std::string name;  ///< e.g. "F315" or "315x232"
  double height_m = 0.0;  ///< box height [m]; 0 = unknown (config formats[].height_mm, optional)
};

/// A box top face placed in the layer plane.
struct Box2d {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< [m], layer frame
  double yaw_rad = 0.0;  ///< direction of the long side, layer frame x -> y [rad]
  double long_m = 0.0;   ///< [m]
  double short_m = 0.0;  ///< [m]
  int format = 0;        ///< index into the recipe's formats

  /// The four corners, counter-clockwise.
  [[nodiscard]] std::vector<Eigen::Vector2d> corners() const;
};

/// Yaw in (-180, 180] degrees of a direction vector's projection onto the x-y plane.
double yaw_deg_of(const Eigen::Vector3d& direction);

/// Yaw of an undirected axis (a box's long side) in (-90, 90] degrees: the rotation of smaller
/// magnitude that a gripper is given.
double axis_yaw_deg(const Eigen::Vector3d& axis);

}  // namespace palletd
