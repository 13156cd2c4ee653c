// Stages 1-2: the top plane (PCL RANSAC, nearest large plane facing the camera, least-squares
// refit) and the layer frame.
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

constexpr double kPi = 3.14159265358979323846;

struct PlaneFit {
  bool ok = false;
  Plane plane;
  double sigma_m = 0.0;
  std::size_t count = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
};

/// Least-squares (total) plane through the usable points within band_m of `plane`.
PlaneFit refit(const OrganizedCloud& cloud, const Plane& plane, double band_m, const PlaneParams& params, int step) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero();
  std::size_t n = 0;
  const Eigen::Vector3f normal = plane.normal.cast<float>();
  const auto d = static_cast<float>(plane.d);
  const auto band = static_cast<float>(band_m);
  for (int v = 0; v < cloud.height; v += step) {
   for (int u = 0; u < cloud.width; u += step) {
    const Eigen::Vector3f& p = cloud.at(u, v);
    if (!usable(p, params)) continue;
    if (std::abs(normal.dot(p) + d) > band) continue;
    const Eigen::Vector3d q = p.cast<double>();
    sum += q;
    sum_sq += q * q.transpose();
    ++n;
   }
  }
  PlaneFit fit;
  if (n < 3) return fit;
  const double count = static_cast<double>(n);
  fit.centroid = sum / count;
  const Eigen::Matrix3d cov = sum_sq / count - fit.centroid * fit.centroid.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d normal_fit = eig.eigenvectors().col(0).normalized();
  if (normal_fit.dot(plane.normal) < 0.0) normal_fit = -normal_fit;
  fit.plane.normal = normal_fit;
  fit.plane.d = -normal_fit.dot(fit.centroid);
  fit.sigma_m = std::sqrt(std::max(0.0, eig.eigenvalues()(0)));
  fit.count = n;
  fit.ok = true;
  return fit;
}

constexpr double kMaxBand = 0.04;  // [m] widest refit band

/// 1.4826 x median |residual| of the usable points within 2 kMaxBand of the plane (every 3rd pixel).
double robust_sigma(const OrganizedCloud& cloud, const Plane& plane, const PlaneParams& params) {
  std::vector<float> r;
  r.reserve(cloud.points.size() / 4);
  const Eigen::Vector3f n = plane.normal.cast<float>();
  const auto d = static_cast<float>(plane.d);
  const auto wide = static_cast<float>(2.0 * kMaxBand);
  for (int v = 1; v < cloud.height; v += 3) {
    for (int u = 1; u < cloud.width; u += 3) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!usable(p, params)) continue;
      const float s = std::abs(n.dot(p) + d);
      if (s < wide) r.push_back(s);
    }
  }
  if (r.empty()) return 0.0;
  auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
  std::nth_element(r.begin(), mid, r.end());
  return 1.4826 * static_cast<double>(*mid);
}

}  // namespace

double pixel_area_m2(double z_m, double plane_distance_m, const Intrinsics& intrinsics) {
  // Footprint of a pixel's solid angle on a plane at distance D: Z^3 / (fx fy D).
  const double dist = std::max(plane_distance_m, 1e-6);
  return z_m * z_m * z_m / (intrinsics.fx * intrinsics.fy * dist);
}

bool usable(const Eigen::Vector3f& p, const PlaneParams& params) {
  if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) return false;
  return p.z() >= params.min_depth_m && p.z() <= params.max_depth_m;
}

TopPlane find_top_plane(const OrganizedCloud& cloud, const Intrinsics& intrinsics,
                        const PlaneParams& params) {
  TopPlane result;
  // PCL prints RANSAC failures to stderr; detection does not log (its result says what failed).
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  for (const Eigen::Vector3f& p : cloud.points)
    if (usable(p, params)) ++result.valid_points;
  // Stride: the configured one, or (0) about 2500 points for RANSAC.
  const int stride = params.ransac_stride_px > 0
                         ? params.ransac_stride_px
                         : std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(result.valid_points) / 2500.0))));
  auto sub = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  sub->reserve(cloud.points.size() / static_cast<std::size_t>(stride * stride) + 1);
  for (int v = stride / 2; v < cloud.height; v += stride) {
    for (int u = stride / 2; u < cloud.width; u += stride) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (usable(p, params)) sub->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    }
  }
  if (sub->size() < 50) {
    result.reason = "too few valid points for a plane search (" + std::to_string(sub->size()) +
                    " after subsampling)";
    return result;
  }
  const double area_per_point_scale = static_cast<double>(stride * stride);

  pcl::Indices remaining(sub->size());
  for (std::size_t i = 0; i < remaining.size(); ++i) remaining[i] = static_cast<int>(i);

  bool have_best = false;
  Plane best;
  double largest_small_area = 0.0;
  for (int round = 0; round < params.max_planes && remaining.size() >= 30; ++round) {
    auto model = pcl::make_shared<pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>>(sub, remaining, false);
    model->setAxis(Eigen::Vector3f(0.0F, 0.0F, 1.0F));
    model->setEpsAngle(params.max_tilt_deg * kPi / 180.0);
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, params.ransac_distance_m);
    ransac.setMaxIterations(params.ransac_max_iterations);
    ransac.setProbability(0.99);
    if (!ransac.computeModel()) break;
    pcl::Indices inliers;
    ransac.getInliers(inliers);
    Eigen::VectorXf coeff;
    ransac.getModelCoefficients(coeff);
    if (inliers.size() < 3 || coeff.size() < 4) break;
    Plane plane;
    plane.normal = coeff.head<3>().cast<double>();
    const double norm = plane.normal.norm();
    if (norm < 1e-9) break;
    plane.normal /= norm;
    plane.d = static_cast<double>(coeff(3)) / norm;
    if (plane.d < 0.0) {  // normal toward the camera (origin on the positive side)
      plane.normal = -plane.normal;
      plane.d = -plane.d;
    }
    double area = 0.0;
    for (const int i : inliers)
      area += pixel_area_m2(static_cast<double>((*sub)[static_cast<std::size_t>(i)].z), plane.d, intrinsics);
    area *= area_per_point_scale;

    pcl::Indices next;
    next.reserve(remaining.size());
    if (area >= params.min_plane_area_m2 && (!have_best || plane.d < best.d)) {
      have_best = true;
      best = plane;
      ++result.candidates;
      // A higher layer lies strictly on the camera side of this one: keep only those points.
      for (const int i : remaining) {
        const pcl::PointXYZ& q = (*sub)[static_cast<std::size_t>(i)];
        const double s = plane.normal.dot(Eigen::Vector3d(q.x, q.y, q.z)) + plane.d;
        if (s > params.ransac_distance_m) next.push_back(i);
      }
    } else {
      largest_small_area = std::max(largest_small_area, area);
      std::vector<char> is_inlier(sub->size(), 0);
      for (const int i : inliers) is_inlier[static_cast<std::size_t>(i)] = 1;
      for (const int i : remaining)
        if (!is_inlier[static_cast<std::size_t>(i)]) next.push_back(i);
    }
    remaining.swap(next);
  }
  if (!have_best) {
    result.reason = largest_small_area > 0.0
                        ? "no plane facing the camera is large enough (largest " +
                              std::to_string(largest_small_area) + " m^2)"
                        : "no plane facing the camera found";
    return result;
  }

  // Refit on full-resolution inliers; then, a few times, a band of 3 robust sigmas (median
  // absolute residual within a wide band, so quantised or noisy sensors get a wide band too).
  // Intermediate fits on every 4th pixel, the last one on every 2nd (>= 10^4 points on a layer
  // of a few boxes at VGA: sub-millimetre for the plane's height).
  PlaneFit fit = refit(cloud, best, params.ransac_distance_m, params, 4);
  for (int k = 0; k < 3 && fit.ok; ++k) {
    const double sigma = robust_sigma(cloud, fit.plane, params);
    const double band = std::clamp(3.0 * sigma, 0.003, kMaxBand);
    const PlaneFit next = refit(cloud, fit.plane, band, params, k == 2 ? 2 : 4);
    if (!next.ok) break;
    fit = next;
    fit.sigma_m = sigma;
  }
  if (!fit.ok) {
    result.reason = "plane refit failed";
    return result;
  }
  result.status = DetectionStatus::ok;
  result.plane = fit.plane;
  result.sigma_m = fit.sigma_m;
  result.inliers = fit.count;
  result.centroid = fit.centroid;
  return result;
}

Eigen::Isometry3d layer_frame(const Plane& plane, const Eigen::Vector3d& origin_camera) {
  const Eigen::Vector3d z = plane.normal.normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z * z.x();
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - z * z.y();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = z;
  T.translation() = origin_camera - z * plane.signed_distance(origin_camera);
  return T;
}

double default_passthrough_tolerance(double sigma_m) {
  // Noise band plus a few millimetres for boxes whose heights differ as built.
  return std::clamp(3.0 * sigma_m + 0.004, 0.006, 0.04);
}

}  // namespace palletd::layer
