// Helpers of the outline-simplification tests: closed outlines walked into points (optionally
// jittered across each edge, seeded), the distance of a point to the nearest vertex, a polygon
// printed for INFO.
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace palletd::testing {

/// Distance from q to the nearest of `points` [m].
inline double nearest(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& q) {
  double best = 1e9;
  for (const auto& p : points) best = std::min(best, (p - q).norm());
  return best;
}

/// Points about every `step_m` along a closed outline, each moved across its edge by a uniform
/// draw in +-jitter_m (outward positive for a counter-clockwise outline; no draw when 0).
inline std::vector<Eigen::Vector2d> walk(const std::vector<Eigen::Vector2d>& outline, double step_m,
                                         double jitter_m = 0.0, std::mt19937* rng = nullptr) {
  std::uniform_real_distribution<double> jitter(-jitter_m, jitter_m);
  std::vector<Eigen::Vector2d> pts;
  for (std::size_t k = 0; k < outline.size(); ++k) {
    const Eigen::Vector2d a = outline[k], b = outline[(k + 1) % outline.size()];
    const Eigen::Vector2d d = (b - a).normalized(), n(d.y(), -d.x());
    const int count = std::max(1, static_cast<int>(std::round((b - a).norm() / step_m)));
    for (int i = 0; i < count; ++i) {
      Eigen::Vector2d p = a + (b - a) * (static_cast<double>(i) / count);
      if (rng != nullptr && jitter_m > 0) p += jitter(*rng) * n;
      pts.push_back(p);
    }
  }
  return pts;
}

/// "(x, y) (x, y) ..." of a polygon's vertices.
inline std::string describe(const std::vector<Eigen::Vector2d>& poly) {
  std::string s;
  for (const auto& c : poly) s += "(" + std::to_string(c.x()) + ", " + std::to_string(c.y()) + ") ";
  return s;
}

}  // namespace palletd::testing
