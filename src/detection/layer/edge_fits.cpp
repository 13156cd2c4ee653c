// Stage 5b: lines and rectangles fitted to a ring's edge samples (simplify_ring's fits).
#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

/// Distance of q to the outline of the rectangle (centre, axis u, half extents h), from inside
/// or outside.
double rect_boundary_distance(const Eigen::Vector2d& q, const Eigen::Vector2d& centre, const Eigen::Vector2d& u,
                              const Eigen::Vector2d& h) {
  const Eigen::Vector2d rel = q - centre;
  const double a = std::abs(rel.dot(u)), b = std::abs(rel.x() * u.y() - rel.y() * u.x());
  const double da = a - h.x(), db = b - h.y();
  if (da <= 0.0 && db <= 0.0) return std::min(-da, -db);
  return std::hypot(std::max(da, 0.0), std::max(db, 0.0));
}

}  // namespace

void fit_line(FittedLine& line) {
  if (line.samples.size() < 3) return;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& s : line.samples) mean += s;
  mean /= static_cast<double>(line.samples.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& s : line.samples) cov += (s - mean) * (s - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  Eigen::Vector2d dir = eig.eigenvectors().col(1).normalized();
  if (dir.dot(line.dir) < 0.0) dir = -dir;
  line.point = mean;
  line.dir = dir;
  line.fitted = true;
}

/// One rectangle through the samples, when they show one: sides fitted to the samples along them
/// (the 2 pitches next to each corner left out) with one common direction. At a coarse pitch the
/// polygon's corners are blunted or its edges laid along pixel runs; the rectangle's are not.
/// Accepted only when 98 % of the samples lie within 1.25 pitches of its outline and each corner
/// within 1.75 pitches of the samples' hull (near a corner seen at a grazing angle the samples
/// stop more than a pitch short of it): a notch, a step between boxes or a corner cut by more
/// than 2.5 pitches along each side (a chamfered or damaged box) keeps the polygon.
/// Orientation: counter-clockwise.
bool fit_rectangle(const std::vector<Eigen::Vector2d>& samples, double pitch_m, Ring2d& rect) {
  if (samples.size() < 16) return false;
  std::vector<cv::Point2f> pts;
  pts.reserve(samples.size());
  for (const auto& p : samples) pts.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  const cv::RotatedRect box = cv::minAreaRect(pts);
  double theta = static_cast<double>(box.angle) * M_PI / 180.0;
  Eigen::Vector2d centre(static_cast<double>(box.center.x), static_cast<double>(box.center.y));
  Eigen::Vector2d h(0.5 * static_cast<double>(box.size.width), 0.5 * static_cast<double>(box.size.height));
  if (std::min(h.x(), h.y()) < 2.0 * pitch_m) return false;
  const double margin = 2.0 * pitch_m;
  for (int iteration = 0; iteration < 3; ++iteration) {
    const Eigen::Vector2d u(std::cos(theta), std::sin(theta)), v(-u.y(), u.x());
    std::array<FittedLine, 4> sides;  // +u, +v, -u, -v
    for (std::size_t k = 0; k < 4; ++k) sides[k].dir = (k % 2 == 0) ? v : u;
    for (const auto& s : samples) {
      const Eigen::Vector2d rel = s - centre;
      const double a = rel.dot(u), b = rel.dot(v);
      const std::array<double, 4> d{std::abs(a - h.x()), std::abs(b - h.y()), std::abs(a + h.x()), std::abs(b + h.y())};
      const auto k = static_cast<std::size_t>(std::min_element(d.begin(), d.end()) - d.begin());
      const double along = (k % 2 == 0) ? std::abs(b) : std::abs(a);
      const double half = (k % 2 == 0) ? h.y() : h.x();
      if (along > half - margin) continue;
      sides[k].samples.push_back(s);
    }
    double c4 = 0.0, s4 = 0.0;
    for (auto& side : sides) {
      if (side.samples.size() < 3) return false;
      fit_line(side);
      const double a = std::atan2(side.dir.y(), side.dir.x());
      const auto n = static_cast<double>(side.samples.size());
      c4 += n * std::cos(4.0 * a);
      s4 += n * std::sin(4.0 * a);
    }
    // The grid angle nearest the current one (angles modulo 90 degrees).
    const double grid = std::atan2(s4, c4) / 4.0;
    theta = grid + std::round((theta - grid) / (M_PI / 2.0)) * (M_PI / 2.0);
    const Eigen::Vector2d u2(std::cos(theta), std::sin(theta)), v2(-u2.y(), u2.x());
    std::array<double, 4> offset{};
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d axis = (k % 2 == 0) ? u2 : v2;
      offset[k] = (sides[k].point - centre).dot(axis);  // the mean of its samples
    }
    const double a_mid = 0.5 * (offset[0] + offset[2]), b_mid = 0.5 * (offset[1] + offset[3]);
    centre += a_mid * u2 + b_mid * v2;
    h = Eigen::Vector2d(0.5 * (offset[0] - offset[2]), 0.5 * (offset[1] - offset[3]));
    if (std::min(h.x(), h.y()) < 2.0 * pitch_m) return false;
  }
  const Eigen::Vector2d u(std::cos(theta), std::sin(theta)), v(-u.y(), u.x());
  std::size_t off = 0;
  for (const auto& s : samples)
    if (std::abs(rect_boundary_distance(s, centre, u, h)) > 1.25 * pitch_m) ++off;
  if (static_cast<double>(off) > 0.02 * static_cast<double>(samples.size())) return false;
  std::vector<cv::Point2f> hull;
  cv::convexHull(pts, hull);
  rect = {centre + h.x() * u + h.y() * v, centre - h.x() * u + h.y() * v, centre - h.x() * u - h.y() * v,
          centre + h.x() * u - h.y() * v};
  for (const auto& c : rect) {
    const cv::Point2f q(static_cast<float>(c.x()), static_cast<float>(c.y()));
    if (-cv::pointPolygonTest(hull, q, true) > 1.75 * pitch_m) return false;  // negative outside the hull
  }
  return true;
}

}  // namespace palletd::layer
