// palletd sim: analytic ray casting of the scene's cuboids (private).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "palletd/sim/sim.hpp"

namespace palletd::sim::detail {

/// A cuboid prepared for ray tests: world -> box-local rotation and the top surface model.
struct PreparedBox {
  const SimBox* box = nullptr;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double c = 1.0, s = 0.0;  ///< cos/sin of yaw
  double hx = 0.0, hy = 0.0;  ///< half sizes [m]
  double z0 = 0.0, z1 = 0.0;  ///< bottom, rim [m]
  double zmax = 0.0, zmin_top = 0.0;  ///< top surface range [m]
  bool flat = true;
  Eigen::Vector3d aabb_lo = Eigen::Vector3d::Zero(), aabb_hi = Eigen::Vector3d::Zero();
};

PreparedBox prepare(const SimBox& box);

struct Hit {
  double t = 0.0;                                  ///< ray parameter
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< world
  double reflectance = 0.5;
};

/// Nearest intersection with t in (t_min, t_best); updates `hit` and returns true when found.
bool intersect(const PreparedBox& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min,
               double t_best, Hit& hit);

/// True when the segment o + t d, t in (t_min, 1), enters the box's bounding cuboid.
bool blocks_segment(const PreparedBox& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min);

}  // namespace palletd::sim::detail
