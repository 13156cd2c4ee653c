// Stages 1-2: the top plane (PCL RANSAC, nearest large plane facing the camera, least-squares
// refit) and the layer frame.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>
#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include "palletd/core/statistics.hpp"

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

/// Points RANSAC searches when PlaneParams::ransac_stride_px is 0 (about).
constexpr double kRansacPoints = 2500.0;
/// Fewest subsampled points worth a plane search.
constexpr std::size_t kMinRansacPoints = 50;
/// Fewest second differences of depth that give a noise estimate for the RANSAC band.
constexpr std::size_t kMinNoiseSamples = 50;
/// Fewest points left worth another RANSAC round.
constexpr std::size_t kMinRoundPoints = 30;
/// RANSAC's wanted probability of drawing one sample of inliers only.
constexpr double kRansacProbability = 0.99;
/// Robust sigma from a median absolute deviation (normal noise).
constexpr double kMadToSigma = 1.4826;
/// Inlier bands are this many sigmas of the depth noise wide.
constexpr double kBandSigmas = 3.0;
/// Widest RANSAC band: a quarter of the step to a layer below [m].
constexpr double kMaxRansacBand_m = 0.25 * kMinLayerStep;
/// Narrowest band of the refits after the first [m].
constexpr double kMinRefitBand_m = 0.003;
/// Refits at the depth noise after the first; all but the last on a coarser pixel grid.
constexpr int kRefits = 3;
constexpr int kCoarseStride_px = 4;
constexpr int kFineStride_px = 2;

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
  // The band lies between min_band_m and kMaxBand: a point's own band decides only between them.
  const auto band_lo = static_cast<float>(std::min(min_band_m, kMaxBand));
  const auto band_hi = static_cast<float>(std::max(min_band_m, kMaxBand));
  for (int v = 0; v < cloud.height; v += step) {
    for (int u = 0; u < cloud.width; u += step) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!usable(p, params)) continue;
      const float r = std::abs(normal.dot(p) + d);
      if (r > band_hi) continue;
      if (r > band_lo &&
          r > static_cast<float>(std::clamp(band_scale * noise.sigma_at(p.z()), min_band_m, kMaxBand)))
        continue;
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

/// DepthNoise::step_per_z2 from (depth, |residual|) samples: the median gap between consecutive
/// distinct depths (10 um apart at least) over the depth squared; 0 with fewer than three.
double depth_step_per_z2(const std::vector<std::pair<float, float>>& zr) {
  std::vector<float> z(zr.size());
  for (std::size_t i = 0; i < zr.size(); ++i) z[i] = zr[i].first;
  std::sort(z.begin(), z.end());
  // Depths within 10 um are one level (a level's depth computed twice may differ in its last bit).
  z.erase(std::unique(z.begin(), z.end(), [](float kept, float next) { return next - kept < 1e-5F; }),
          z.end());
  if (z.size() < 3) return 0.0;
  std::vector<double> per_z2;
  per_z2.reserve(z.size() - 1);
  for (std::size_t i = 1; i < z.size(); ++i) {
    const double mid = 0.5 * static_cast<double>(z[i] + z[i - 1]);
    per_z2.push_back(static_cast<double>(z[i] - z[i - 1]) / (mid * mid));
  }
  return upper_median(std::move(per_z2));
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
  out.step_per_z2 = depth_step_per_z2(zr);
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

// ---- find_top_plane's phases --------------------------------------------------------------------

/// The subsampled cloud RANSAC searches, and its inlier band.
struct RansacInput {
  pcl::PointCloud<pcl::PointXYZ>::Ptr points;  ///< every stride_px-th usable pixel in u and v
  int stride_px = 1;
  double band_m = 0.0;  ///< RANSAC inlier band [m]
  Eigen::Vector3f axis = Eigen::Vector3f::UnitZ();  ///< a plane's normal lies within max_angle_rad of this
  double max_angle_rad = 0.0;
};

/// The nearest plane facing the camera with enough area, as the RANSAC rounds found it.
struct PlaneSearch {
  bool found = false;
  Plane best;
  double largest_small_area_m2 = 0.0;  ///< largest plane seen with too little area [m^2]
  std::size_t candidates = 0;          ///< planes with enough area seen on the way
};

/// RANSAC stride: the configured one, or (0) one that leaves about kRansacPoints points.
int ransac_stride_px(const PlaneParams& params, std::size_t valid_points) {
  if (params.ransac_stride_px > 0) return params.ransac_stride_px;
  return std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(valid_points) / kRansacPoints))));
}

/// RANSAC inlier band: kBandSigmas sigma of the depth noise (sigma = 1.4826 MAD / sqrt(6) of the
/// second differences; reorders `second_diff`), at least the configured distance, at most
/// kMaxRansacBand_m (a wider band lets a tilted plane collect points of two layers; the refit
/// widens the band per depth afterwards). The configured distance with too few differences.
double ransac_band_m(std::vector<float>& second_diff, const PlaneParams& params) {
  double ransac_band = params.ransac_distance_m;
  if (second_diff.size() >= kMinNoiseSamples) {
    auto mid = second_diff.begin() + static_cast<std::ptrdiff_t>(second_diff.size() / 2);
    std::nth_element(second_diff.begin(), mid, second_diff.end());
    const double sigma = kMadToSigma * static_cast<double>(*mid) / std::sqrt(6.0);
    ransac_band = std::clamp(kBandSigmas * sigma, params.ransac_distance_m,
                             std::max(kMaxRansacBand_m, params.ransac_distance_m));
  }
  return ransac_band;
}

/// The points RANSAC searches and its band. The depth noise before any plane is known: second
/// differences of depth along image rows at the sampled pixels (a smooth surface has none; depth
/// edges are outliers of the median).
RansacInput ransac_input(const OrganizedCloud& cloud, const PlaneParams& params, std::size_t valid_points) {
  RansacInput in;
  in.stride_px = ransac_stride_px(params, valid_points);
  const int stride = in.stride_px;
  in.points = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  in.points->reserve(cloud.points.size() / static_cast<std::size_t>(stride * stride) + 1);
  std::vector<float> second_diff;
  second_diff.reserve(cloud.points.size() / static_cast<std::size_t>(stride * stride) + 1);
  for (int v = stride / 2; v < cloud.height; v += stride) {
    for (int u = stride / 2; u < cloud.width; u += stride) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!usable(p, params)) continue;
      in.points->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
      if (u < 1 || u + 1 >= cloud.width) continue;
      const Eigen::Vector3f& a = cloud.at(u - 1, v);
      const Eigen::Vector3f& b = cloud.at(u + 1, v);
      if (usable(a, params) && usable(b, params)) second_diff.push_back(std::abs(a.z() - 2.0F * p.z() + b.z()));
    }
  }
  in.band_m = ransac_band_m(second_diff, params);
  return in;
}

/// One seeded RANSAC round on the remaining points for a plane whose normal lies within
/// in.max_angle_rad of in.axis: the plane (unit normal toward the camera) and its inliers; false
/// when there is none.
bool ransac_round(const RansacInput& in, const pcl::Indices& remaining, std::uint32_t seed,
                  const PlaneParams& params, Plane& plane, pcl::Indices& inliers) {
  auto model = pcl::make_shared<SeededPlaneModel>(in.points, remaining, seed);
  model->setAxis(in.axis);
  model->setEpsAngle(in.max_angle_rad);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, in.band_m);
  ransac.setMaxIterations(params.ransac_max_iterations);
  ransac.setProbability(kRansacProbability);
  if (!ransac.computeModel()) return false;
  ransac.getInliers(inliers);
  Eigen::VectorXf coeff;
  ransac.getModelCoefficients(coeff);
  if (inliers.size() < 3 || coeff.size() < 4) return false;
  plane.normal = coeff.head<3>().cast<double>();
  const double norm = plane.normal.norm();
  if (norm < 1e-9) return false;
  plane.normal /= norm;
  plane.d = static_cast<double>(coeff(3)) / norm;
  if (plane.d < 0.0) {  // normal toward the camera (origin on the positive side)
    plane.normal = -plane.normal;
    plane.d = -plane.d;
  }
  return true;
}

/// The area the inliers cover on the plane: each stands for stride_px^2 pixels [m^2].
double inlier_area_m2(const RansacInput& in, const pcl::Indices& inliers, const Plane& plane,
                      const Intrinsics& intrinsics) {
  double area = 0.0;
  for (const int i : inliers) {
    const pcl::PointXYZ& q = (*in.points)[static_cast<std::size_t>(i)];
    area += pixel_area_m2(static_cast<double>(q.z), plane.d, intrinsics);
  }
  area *= static_cast<double>(in.stride_px * in.stride_px);
  return area;
}

/// Up to max_planes RANSAC rounds, each on the points the rounds before left: a plane with enough
/// area nearer than the best so far becomes the best, and only the points beyond its band on the
/// camera side (a higher layer) are left; any other plane leaves all but its inliers.
PlaneSearch search_planes(const RansacInput& in, const Intrinsics& intrinsics, const PlaneParams& params) {
  const pcl::PointCloud<pcl::PointXYZ>& sub = *in.points;
  pcl::Indices remaining(sub.size());
  for (std::size_t i = 0; i < remaining.size(); ++i) remaining[i] = static_cast<int>(i);
  PlaneSearch search;
  for (int round = 0; round < params.max_planes && remaining.size() >= kMinRoundPoints; ++round) {
    Plane plane;
    pcl::Indices inliers;
    const std::uint32_t seed = params.seed + static_cast<std::uint32_t>(round);
    if (!ransac_round(in, remaining, seed, params, plane, inliers)) break;
    const double area = inlier_area_m2(in, inliers, plane, intrinsics);
    pcl::Indices next;
    next.reserve(remaining.size());
    if (area >= params.min_plane_area_m2 && (!search.found || plane.d < search.best.d)) {
      search.found = true;
      search.best = plane;
      ++search.candidates;
      // A higher layer lies strictly on the camera side of this one: keep only those points.
      for (const int i : remaining) {
        const pcl::PointXYZ& q = sub[static_cast<std::size_t>(i)];
        const double s = plane.normal.dot(Eigen::Vector3d(q.x, q.y, q.z)) + plane.d;
        if (s > in.band_m) next.push_back(i);
      }
    } else {
      search.largest_small_area_m2 = std::max(search.largest_small_area_m2, area);
      std::vector<char> is_inlier(sub.size(), 0);
      for (const int i : inliers) is_inlier[static_cast<std::size_t>(i)] = 1;
      for (const int i : remaining)
        if (!is_inlier[static_cast<std::size_t>(i)]) next.push_back(i);
    }
    remaining.swap(next);
  }
  return search;
}

/// The cloud's points on the camera side of `plane` by more than kMaxBand (a higher level), on a
/// pixel grid that keeps about kRansacPoints of them; band and axis as in `like`.
RansacInput points_above(const OrganizedCloud& cloud, const Plane& plane, const RansacInput& like,
                         const PlaneParams& params) {
  const Eigen::Vector3f n = plane.normal.cast<float>();
  const auto d = static_cast<float>(plane.d);
  const auto step = static_cast<float>(kMaxBand);
  std::vector<int> above;  // pixel indices, row-major
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (usable(p, params) && n.dot(p) + d > step) above.push_back(static_cast<int>(i));
  }
  RansacInput in = like;
  in.points = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  in.stride_px = std::max(
      1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(above.size()) / kRansacPoints))));
  const int stride = in.stride_px;
  for (const int i : above) {  // the pixels (stride / 2 + k stride, stride / 2 + l stride)
    const int u = i % cloud.width, v = i / cloud.width;
    if (u % stride != stride / 2 || v % stride != stride / 2) continue;
    const Eigen::Vector3f& p = cloud.points[static_cast<std::size_t>(i)];
    in.points->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  return in;
}

/// The subsampled search sees a level of one or two boxes far from the camera with a few dozen
/// points and may miss it: look again among the points above the best plane, on a grid that
/// samples them densely, until no higher level with enough area is left.
void search_higher_levels(const OrganizedCloud& cloud, const RansacInput& in, const Intrinsics& intrinsics,
                          const PlaneParams& params, PlaneSearch& search) {
  constexpr int kMaxHigherLevels = 3;
  for (int k = 0; k < kMaxHigherLevels && search.found; ++k) {
    const RansacInput above = points_above(cloud, search.best, in, params);
    if (above.points->size() < kMinRansacPoints) return;
    const PlaneSearch higher = search_planes(above, intrinsics, params);
    if (!higher.found) return;
    search.best = higher.best;
    search.candidates += higher.candidates;
  }
}

/// Least-squares refit of the RANSAC plane, first within the RANSAC band; then kRefits times
/// within kBandSigmas robust sigmas at each point's depth (the residuals' median absolute
/// deviation per depth bin, so quantised, noisy or far sensors get a wide band where they need
/// it). The fits before the last use every kCoarseStride_px-th pixel, the last every
/// kFineStride_px-th (>= 10^4 points on a layer of a few boxes at VGA: sub-millimetre for the
/// plane's height). Stops at the first refit that fails, keeping the fit before it. `noise`: the
/// depth noise of the last refit tried.
PlaneFit refine_plane(const OrganizedCloud& cloud, const Plane& plane, double ransac_band,
                      const PlaneParams& params, DepthNoise& noise) {
  noise = DepthNoise{};
  noise.sigma_all_m = ransac_band / kBandSigmas;
  PlaneFit fit = refit(cloud, plane, noise, kBandSigmas, ransac_band, params, kCoarseStride_px);
  for (int k = 0; k < kRefits && fit.ok; ++k) {
    noise = depth_noise(cloud, fit.plane, params);
    const int stride_px = k == kRefits - 1 ? kFineStride_px : kCoarseStride_px;
    const PlaneFit next = refit(cloud, fit.plane, noise, kBandSigmas, kMinRefitBand_m, params, stride_px);
    if (!next.ok) break;
    fit = next;
  }
  return fit;
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

double DepthNoise::band_at(double z_m) const {
  return std::max(default_passthrough_tolerance(sigma_at(z_m)),
                  std::min(step_at(z_m) + kBandMargin_m, kMaxBand));
}

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
                        const PlaneParams& params, std::size_t usable_points,
                        const std::optional<Eigen::Vector3d>& up_camera) {
  TopPlane result;
  // PCL prints RANSAC failures to stderr; detection does not log (its result says what failed).
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  result.valid_points = usable_points;
  if (usable_points == 0)
    for (const Eigen::Vector3f& p : cloud.points)
      if (usable(p, params)) ++result.valid_points;
  RansacInput in = ransac_input(cloud, params, result.valid_points);
  // Level layers when the calibration says which way is up; else planes facing the camera.
  in.axis = up_camera ? Eigen::Vector3f(up_camera->normalized().cast<float>()) : Eigen::Vector3f::UnitZ();
  in.max_angle_rad = (up_camera ? params.max_base_tilt_deg : params.max_tilt_deg) * M_PI / 180.0;
  if (in.points->size() < kMinRansacPoints) {
    result.reason = "too few valid points for a plane search (" + std::to_string(in.points->size()) +
                    " after subsampling)";
    return result;
  }

  PlaneSearch search = search_planes(in, intrinsics, params);
  search_higher_levels(cloud, in, intrinsics, params, search);
  result.candidates = search.candidates;
  if (!search.found) {
    result.reason = search.largest_small_area_m2 > 0.0
                        ? "no " + std::string(up_camera ? "level plane" : "plane facing the camera") +
                              " is large enough (largest " + std::to_string(search.largest_small_area_m2) + " m^2)"
                        : "no " + std::string(up_camera ? "level plane (within detection.plane.max_base_tilt_deg "
                                                          "of the base +z axis)"
                                                        : "plane facing the camera") +
                              " found";
    return result;
  }

  DepthNoise noise;
  const PlaneFit fit = refine_plane(cloud, search.best, in.band_m, params, noise);
  if (!fit.ok) {
    result.reason = "plane refit failed";
    return result;
  }
  result.status = DetectionStatus::kOk;
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
  return std::clamp(3.0 * sigma_m + kBandMargin_m, 0.006, kMaxBand);
}

}  // namespace palletd::layer
