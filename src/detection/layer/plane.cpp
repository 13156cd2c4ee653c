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

/// PCL's plane model with its random generator seeded from PlaneParams::seed (PCL seeds every
/// model with a fixed 12345; the generator is a protected member, so a subclass sets it).
class SeededPlaneModel : public pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ> {
 public:
  SeededPlaneModel(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud, const pcl::Indices& indices, std::uint32_t seed)
      : pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>(cloud, indices, false) {
    rng_alg_.seed(seed);
  }
};

/// Least-squares (total) plane through the usable points within the noise band of `plane`
/// (band_scale x sigma at each point's depth, at least min_band_m).
PlaneFit refit(const OrganizedCloud& cloud, const Plane& plane, const DepthNoise& noise, double band_scale,
               double min_band_m, const PlaneParams& params, int step) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_sq = Eigen::Matrix3d::Zero();
  std::size_t n = 0;
  const Eigen::Vector3f normal = plane.normal.cast<float>();
  const auto d = static_cast<float>(plane.d);
  for (int v = 0; v < cloud.height; v += step) {
    for (int u = 0; u < cloud.width; u += step) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!usable(p, params)) continue;
      const auto band = static_cast<float>(std::clamp(band_scale * noise.sigma_at(p.z()), min_band_m, kMaxBand));
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

/// Robust sigma (1.4826 x median |residual|) of the points near the plane (at most ~10^4
/// samples), overall and in up to kDepthBins depth bins of equal count: noise grows with range
/// (ToF linearly, structured light with its square), so the band follows the depth. Points
/// further than 0.8 of the step to a layer below are left out.
DepthNoise depth_noise(const OrganizedCloud& cloud, const Plane& plane, const PlaneParams& params) {
  constexpr int kDepthBins = 6;
  constexpr std::size_t kMinPerBin = 300;
  std::vector<std::pair<float, float>> zr;  // depth, |residual|
  zr.reserve(cloud.points.size() / 9 + 1);  // (at most)
  const Eigen::Vector3f n = plane.normal.cast<float>();
  const auto d = static_cast<float>(plane.d);
  const auto window = static_cast<float>(0.8 * kMinLayerStep);
  // About 10^4 samples at most: every 3rd pixel of small frames, sparser at VGA.
  const int step = std::max(3, static_cast<int>(std::sqrt(static_cast<double>(cloud.points.size()) / 1e4)));
  for (int v = 1; v < cloud.height; v += step) {
    for (int u = 1; u < cloud.width; u += step) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!usable(p, params)) continue;
      const float s = std::abs(n.dot(p) + d);
      if (s < window) zr.emplace_back(p.z(), s);
    }
  }
  DepthNoise out;
  if (zr.empty()) return out;
  auto mad = [](std::vector<float>& r) {
    auto mid = r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2);
    std::nth_element(r.begin(), mid, r.end());
    return 1.4826 * static_cast<double>(*mid);
  };
  std::vector<float> r(zr.size());
  for (std::size_t i = 0; i < zr.size(); ++i) r[i] = zr[i].second;
  out.sigma_all_m = mad(r);
  const int bins = static_cast<int>(std::min<std::size_t>(kDepthBins, zr.size() / kMinPerBin));
  if (bins < 2) return out;
  std::sort(zr.begin(), zr.end());
  for (int b = 0; b < bins; ++b) {
    const std::size_t lo = zr.size() * static_cast<std::size_t>(b) / static_cast<std::size_t>(bins);
    const std::size_t hi = zr.size() * static_cast<std::size_t>(b + 1) / static_cast<std::size_t>(bins);
    r.clear();
    for (std::size_t i = lo; i < hi; ++i) r.push_back(zr[i].second);
    out.bin_z_m.push_back(static_cast<double>(zr[(lo + hi) / 2].first));
    out.bin_sigma_m.push_back(mad(r));
  }
  return out;
}

}  // namespace

double DepthNoise::sigma_at(double z_m) const {
  if (bin_z_m.empty()) return sigma_all_m;
  if (z_m <= bin_z_m.front()) return bin_sigma_m.front();
  if (z_m >= bin_z_m.back()) return bin_sigma_m.back();
  std::size_t k = 1;
  while (k + 1 < bin_z_m.size() && bin_z_m[k] < z_m) ++k;
  const double t = (z_m - bin_z_m[k - 1]) / std::max(bin_z_m[k] - bin_z_m[k - 1], 1e-9);
  return bin_sigma_m[k - 1] + t * (bin_sigma_m[k] - bin_sigma_m[k - 1]);
}

double DepthNoise::band_at(double z_m) const { return default_passthrough_tolerance(sigma_at(z_m)); }

BandTable::BandTable(const DepthNoise& noise, double fixed_m) {
  if (fixed_m > 0.0 || noise.bin_z_m.size() < 2) {
    const double b = fixed_m > 0.0 ? fixed_m : default_passthrough_tolerance(noise.sigma_all_m);
    band_.assign(1, static_cast<float>(b));
    max_m_ = min_m_ = b;
    return;
  }
  // 5 mm depth steps from the first to the last bin centre (constant beyond).
  constexpr double kStep = 0.005;
  const double z0 = noise.bin_z_m.front(), z1 = noise.bin_z_m.back();
  const auto n = static_cast<std::size_t>(std::ceil((z1 - z0) / kStep)) + 1;
  z0_ = static_cast<float>(z0);
  inv_step_ = static_cast<float>(1.0 / kStep);
  band_.resize(std::min<std::size_t>(n, 4096));
  max_m_ = 0.0;
  min_m_ = 1e9;
  for (std::size_t i = 0; i < band_.size(); ++i) {
    const double b = noise.band_at(z0 + (static_cast<double>(i) + 0.5) * kStep);
    band_[i] = static_cast<float>(b);
    max_m_ = std::max(max_m_, b);
    min_m_ = std::min(min_m_, b);
  }
}

double pixel_area_m2(double z_m, double plane_distance_m, const Intrinsics& intrinsics) {
  // Footprint of a pixel's solid angle on a plane at distance D: Z^3 / (fx fy D).
  const double dist = std::max(plane_distance_m, 1e-6);
  return z_m * z_m * z_m / (intrinsics.fx * intrinsics.fy * dist);
}

TopPlane find_top_plane(const OrganizedCloud& cloud, const Intrinsics& intrinsics,
                        const PlaneParams& params, std::size_t usable_points) {
  TopPlane result;
  // PCL prints RANSAC failures to stderr; detection does not log (its result says what failed).
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  result.valid_points = usable_points;
  if (usable_points == 0)
    for (const Eigen::Vector3f& p : cloud.points)
      if (usable(p, params)) ++result.valid_points;
  // Stride: the configured one, or (0) about 2500 points for RANSAC.
  const int stride = params.ransac_stride_px > 0
                         ? params.ransac_stride_px
                         : std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(result.valid_points) / 2500.0))));
  auto sub = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  sub->reserve(cloud.points.size() / static_cast<std::size_t>(stride * stride) + 1);
  // Depth noise before any plane is known: second differences of depth along image rows at the
  // sampled pixels (a smooth surface has none; depth edges are outliers of the median).
  std::vector<float> second_diff;
  second_diff.reserve(cloud.points.size() / static_cast<std::size_t>(stride * stride) + 1);
  for (int v = stride / 2; v < cloud.height; v += stride) {
    for (int u = stride / 2; u < cloud.width; u += stride) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!usable(p, params)) continue;
      sub->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
      if (u < 1 || u + 1 >= cloud.width) continue;
      const Eigen::Vector3f& a = cloud.at(u - 1, v);
      const Eigen::Vector3f& b = cloud.at(u + 1, v);
      if (usable(a, params) && usable(b, params)) second_diff.push_back(std::abs(a.z() - 2.0F * p.z() + b.z()));
    }
  }
  // RANSAC inlier band: 3 sigma of that noise (sigma = 1.4826 MAD / sqrt(6)), at least the
  // configured distance, at most a quarter of the step to a layer below (a wider band lets a
  // tilted plane collect points of two layers; the refit widens the band per depth afterwards).
  double ransac_band = params.ransac_distance_m;
  if (second_diff.size() >= 50) {
    auto mid = second_diff.begin() + static_cast<std::ptrdiff_t>(second_diff.size() / 2);
    std::nth_element(second_diff.begin(), mid, second_diff.end());
    const double sigma = 1.4826 * static_cast<double>(*mid) / std::sqrt(6.0);
    ransac_band = std::clamp(3.0 * sigma, params.ransac_distance_m, std::max(0.25 * kMinLayerStep, params.ransac_distance_m));
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
    auto model = pcl::make_shared<SeededPlaneModel>(sub, remaining, params.seed + static_cast<std::uint32_t>(round));
    model->setAxis(Eigen::Vector3f(0.0F, 0.0F, 1.0F));
    model->setEpsAngle(params.max_tilt_deg * kPi / 180.0);
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, ransac_band);
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
        if (s > ransac_band) next.push_back(i);
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

  // Refit on full-resolution inliers; then, a few times, a band of 3 robust sigmas at each
  // point's depth (median absolute residual near the plane per depth bin, so quantised, noisy or
  // far sensors get a wide band where they need it). Intermediate fits on every 4th pixel, the
  // last one on every 2nd (>= 10^4 points on a layer of a few boxes at VGA: sub-millimetre for
  // the plane's height).
  DepthNoise noise;
  noise.sigma_all_m = ransac_band / 3.0;
  PlaneFit fit = refit(cloud, best, noise, 3.0, ransac_band, params, 4);
  for (int k = 0; k < 3 && fit.ok; ++k) {
    noise = depth_noise(cloud, fit.plane, params);
    const PlaneFit next = refit(cloud, fit.plane, noise, 3.0, 0.003, params, k == 2 ? 2 : 4);
    if (!next.ok) break;
    fit = next;
  }
  if (!fit.ok) {
    result.reason = "plane refit failed";
    return result;
  }
  result.status = DetectionStatus::ok;
  result.plane = fit.plane;
  result.sigma_m = noise.sigma_all_m;
  result.noise = noise;
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
  // Noise band plus a few millimetres for boxes whose heights differ as built; never wider than
  // half the smallest step to the layer below.
  return std::clamp(3.0 * sigma_m + 0.004, 0.006, kMaxBand);
}

}  // namespace palletd::layer
