#include "palletd/core/geometry.hpp"

#include <cmath>

namespace palletd {

double signed_area(const Ring2d& ring) {
  const std::size_t n = ring.size();
  if (n < 3) return 0.0;
  double twice = 0.0;
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    twice += ring[j].x() * ring[i].y() - ring[i].x() * ring[j].y();
  }
  return 0.5 * twice;
}

double area(const PolygonWithHoles& polygon) {
  double a = std::abs(signed_area(polygon.outer));
  for (const auto& hole : polygon.holes) a -= std::abs(signed_area(hole));
  return a;
}

std::vector<Eigen::Vector2d> Box2d::corners() const {
  const Eigen::Vector2d ux(std::cos(yaw_rad), std::sin(yaw_rad));
  const Eigen::Vector2d uy(-ux.y(), ux.x());
  const Eigen::Vector2d a = 0.5 * long_m * ux;
  const Eigen::Vector2d b = 0.5 * short_m * uy;
  return {center - a - b, center + a - b, center + a + b, center - a + b};
}

double yaw_deg_of(const Eigen::Vector3d& direction) {
  double deg = std::atan2(direction.y(), direction.x()) * 180.0 / M_PI;
  if (deg <= -180.0) deg += 360.0;
  return deg;
}

double axis_yaw_deg(const Eigen::Vector3d& axis) {
  double deg = std::atan2(axis.y(), axis.x()) * 180.0 / M_PI;
  while (deg > 90.0) deg -= 180.0;
  while (deg <= -90.0) deg += 180.0;
  return deg;
}

}  // namespace palletd
