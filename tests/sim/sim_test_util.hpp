// Helpers shared by the simulator tests.
#pragma once

#include <cmath>

#include "palletd/sim/sim.hpp"

namespace palletd::sim::test {

/// Camera `height_m` above the floor, looking down, tilted by `tilt_deg` toward +x.
inline Eigen::Isometry3d look_down(double height_m, double tilt_deg) {
  const double t = tilt_deg * 3.14159265358979323846 / 180.0;
  const Eigen::Vector3d z(std::sin(t), 0.0, -std::cos(t));
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = z.cross(x);
  T.linear().col(2) = z;
  T.translation() = Eigen::Vector3d(0.0, 0.0, height_m);
  return T;
}

/// A scene with nothing but the floor.
inline Scene floor_scene(double height_m, double tilt_deg, double reflectance) {
  Scene s;
  s.pallet = PalletKind::kNone;
  s.floor_reflectance = reflectance;
  s.T_world_camera = look_down(height_m, tilt_deg);
  return s;
}

/// Options without any random surface effect (for exact geometry tests).
inline ScenarioOptions ideal_boxes(PatternFamily pattern) {
  ScenarioOptions o;
  o.pattern = pattern;
  o.bulge_max_m = 0.0;
  o.bevel_m = 0.0;
  o.height_tolerance_m = 0.0;
  return o;
}

inline RenderOptions noise_free() {
  RenderOptions r;
  r.noise = false;
  r.invalid = false;
  r.multipath = false;
  r.supersampling = 1;
  return r;
}

}  // namespace palletd::sim::test
