// palletd sim: the renderer. Ray casts each pixel's footprint (n x n rays), mixes the samples the
// way the sensor kind does, then applies the sensor's noise, dropouts, multipath and quantisation.
#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "raycast.hpp"
#include "sim_internal.hpp"

namespace palletd::sim {
namespace {

using detail::Hit;
using detail::PreparedBox;
using detail::Rng;

constexpr int kTile = 8;  // [px]
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Boxes whose projection may cover each 8x8 pixel tile.
std::vector<std::vector<int>> tile_lists(const std::vector<PreparedBox>& boxes, const Eigen::Isometry3d& T_camera_world,
                                         const Intrinsics& k, int tiles_x, int tiles_y) {
  std::vector<std::vector<int>> tiles(static_cast<std::size_t>(tiles_x * tiles_y));
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const SimBox& b = *boxes[i].box;
    double umin = kInf, vmin = kInf, umax = -kInf, vmax = -kInf;
    bool behind = false;
    for (const auto& c : detail::footprint_corners(b.center, b.yaw_rad, b.long_m, b.short_m))
      for (double z : {boxes[i].z0, boxes[i].zmax}) {
        const Eigen::Vector3d p = T_camera_world * Eigen::Vector3d(c.x(), c.y(), z);
        if (p.z() < 0.05) {
          behind = true;
          continue;
        }
        const double u = k.fx * p.x() / p.z() + k.cx, v = k.fy * p.y() / p.z() + k.cy;
        umin = std::min(umin, u);
        umax = std::max(umax, u);
        vmin = std::min(vmin, v);
        vmax = std::max(vmax, v);
      }
    int tx0 = 0, ty0 = 0, tx1 = tiles_x - 1, ty1 = tiles_y - 1;
    if (!behind) {
      if (umax < -1.0 || vmax < -1.0 || umin > k.width || vmin > k.height) continue;
      tx0 = std::max(0, static_cast<int>(std::floor((umin - 1.0) / kTile)));
      ty0 = std::max(0, static_cast<int>(std::floor((vmin - 1.0) / kTile)));
      tx1 = std::min(tiles_x - 1, static_cast<int>(std::floor((umax + 1.0) / kTile)));
      ty1 = std::min(tiles_y - 1, static_cast<int>(std::floor((vmax + 1.0) / kTile)));
    }
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx) tiles[static_cast<std::size_t>(ty * tiles_x + tx)].push_back(static_cast<int>(i));
  }
  // Higher boxes first: they are usually nearer, so the rays reject the boxes below them early.
  for (auto& list : tiles)
    std::sort(list.begin(), list.end(), [&](int a, int b) {
      const PreparedBox& pa = boxes[static_cast<std::size_t>(a)];
      const PreparedBox& pb = boxes[static_cast<std::size_t>(b)];
      return pa.zmax != pb.zmax ? pa.zmax > pb.zmax : a < b;
    });
  return tiles;
}

/// Multipath: extra range on surfaces at the foot of a depth step (light bounced off the face).
std::vector<float> multipath_bias(const std::vector<float>& z, int w, int h, const SensorProfile& profile) {
  std::vector<float> bias(z.size(), 0.0f);
  std::vector<float> sorted = z;
  const auto mid = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), mid, sorted.end());
  const double z_typ = std::max(0.3, static_cast<double>(*mid));
  const int radius = std::max(1, static_cast<int>(std::ceil(profile.multipath_range_m * profile.intrinsics.fx / z_typ)));
  const cv::Mat depth(h, w, CV_32F, const_cast<float*>(z.data()));  // read only
  cv::Mat zmin;
  cv::erode(depth, zmin, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1)));
  const float step = 0.02f;  // [m]
  cv::Mat foot(h, w, CV_8U, cv::Scalar(255));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const float zp = depth.at<float>(v, u);
      const bool at_step = (u > 0 && depth.at<float>(v, u - 1) < zp - step) ||
                           (u + 1 < w && depth.at<float>(v, u + 1) < zp - step) ||
                           (v > 0 && depth.at<float>(v - 1, u) < zp - step) ||
                           (v + 1 < h && depth.at<float>(v + 1, u) < zp - step);
      if (at_step) foot.at<std::uint8_t>(v, u) = 0;
    }
  cv::Mat dist;
  cv::distanceTransform(foot, dist, cv::DIST_L2, 3);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const float zp = depth.at<float>(v, u);
      if (zp - zmin.at<float>(v, u) < step) continue;  // not below a nearby step
      const double share = 1.0 - static_cast<double>(dist.at<float>(v, u)) / radius;
      if (share > 0.0)
        bias[static_cast<std::size_t>(v * w + u)] = static_cast<float>(profile.multipath_bias_m * share);
    }
  return bias;
}

struct PixelSignal {
  double z = 0.0;          ///< mixed depth [m], 0 = nothing measured
  double amplitude = 0.0;  ///< mean rho cos / r^2 of the samples [1/m^2]
  double spread = 0.0;     ///< max - min sample depth [m]
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< world point of the chosen sample (SL)
};

constexpr double kRayTMin = 1e-6;              ///< nearest ray parameter a box hit may have
constexpr double kReferenceRange_m = 2.0;      ///< range of the intensity reference surface
constexpr double kIntensityNoiseFloor = 1e-4;  ///< intensity noise without signal [full scale]
constexpr double kEdgeSpread_m = 0.02;         ///< SL: footprint depth spread that makes an edge pixel
constexpr double kEdgeDropChance = 0.5;        ///< SL: chance an edge pixel finds no pattern match
constexpr double kShadowClearance_m = 1e-3;    ///< SL: boxes lower than the point + this cast no shadow
constexpr double kShadowTMin = 1e-3;           ///< SL: nearest segment parameter a shadowing box may have

/// The scene as the rays see it, prepared once per frame.
struct RayScene {
  std::vector<PreparedBox> boxes;
  Eigen::Matrix3d rotation;  ///< camera -> world (of T_world_camera)
  Eigen::Vector3d origin;    ///< camera centre, world [m]
  double floor_reflectance = 0.0;
  int tiles_x = 0;                      ///< tiles per image row
  std::vector<std::vector<int>> tiles;  ///< per kTile x kTile tile: boxes it may see (tile_lists)
};

/// Prepares the boxes for ray tests and lists, per image tile, the boxes it may see.
RayScene prepare_rays(const Scene& scene, const Intrinsics& k) {
  RayScene rays;
  rays.boxes.reserve(scene.boxes.size());
  for (const SimBox& b : scene.boxes) rays.boxes.push_back(detail::prepare(b));
  rays.rotation = scene.T_world_camera.linear();
  rays.origin = scene.T_world_camera.translation();
  rays.floor_reflectance = scene.floor_reflectance;
  const int w = k.width, h = k.height;
  rays.tiles_x = (w + kTile - 1) / kTile;
  const int tiles_y = (h + kTile - 1) / kTile;
  rays.tiles = tile_lists(rays.boxes, scene.T_world_camera.inverse(), k, rays.tiles_x, tiles_y);
  return rays;
}

/// Nearest hit of the ray origin + t d on the floor (z = 0) or a box of `list` (t = inf: none).
Hit nearest_hit(const RayScene& rays, const std::vector<int>& list, const Eigen::Vector3d& d) {
  const Eigen::Vector3d& o = rays.origin;
  Hit best;
  best.t = kInf;
  if (d.z() < 0.0) {  // the floor, z = 0
    best.t = -o.z() / d.z();
    best.normal = Eigen::Vector3d::UnitZ();
    best.reflectance = rays.floor_reflectance;
  }
  double hit_z = d.z() < 0.0 ? 0.0 : -kInf;  // height of the nearest hit so far
  for (int bi : list) {
    const PreparedBox& box = rays.boxes[static_cast<std::size_t>(bi)];
    // A downward ray reaches a box lower than its current hit only after that hit; the
    // list is sorted by height, so no later box can be nearer.
    if (box.zmax < hit_z) break;
    Hit hit;
    if (detail::intersect(box, o, d, kRayTMin, best.t, hit)) {
      best = hit;
      hit_z = o.z() + best.t * d.z();
    }
  }
  return best;
}

/// The rays of one pixel's footprint that hit something; reused from pixel to pixel.
struct Samples {
  explicit Samples(std::size_t size) : zs(size), as(size), points(size), order(size) {}
  std::vector<double> zs;               ///< camera Z of the hit [m]
  std::vector<double> as;               ///< rho cos / r^2 of the hit [1/m^2]
  std::vector<Eigen::Vector3d> points;  ///< world point of the hit
  std::vector<std::size_t> order;       ///< scratch of mix_samples()
  std::size_t count = 0;                ///< samples of the current pixel
};

/// Casts pixel (u, v)'s ss x ss rays (a regular grid over its footprint) into `samples`.
void sample_footprint(const RayScene& rays, const Intrinsics& k, int u, int v, int ss, Samples& samples) {
  const Eigen::Vector3d& o = rays.origin;
  const auto& list = rays.tiles[static_cast<std::size_t>((v / kTile) * rays.tiles_x + u / kTile)];
  std::size_t count = 0;
  for (int sy = 0; sy < ss; ++sy)
    for (int sx = 0; sx < ss; ++sx) {
      const double pu = u + (sx + 0.5) / ss - 0.5, pv = v + (sy + 0.5) / ss - 0.5;
      const Eigen::Vector3d dir_cam((pu - k.cx) / k.fx, (pv - k.cy) / k.fy, 1.0);
      const Eigen::Vector3d d = rays.rotation * dir_cam;
      const Hit best = nearest_hit(rays, list, d);
      if (!std::isfinite(best.t)) continue;
      const double len = dir_cam.norm();
      const double range = best.t * len;
      const double cos_inc = std::abs(best.normal.dot(d)) / len;
      samples.zs[count] = best.t;  // t is the camera Z because dir_cam.z = 1
      samples.as[count] = best.reflectance * cos_inc / (range * range);
      samples.points[count] = o + best.t * d;
      ++count;
    }
  samples.count = count;
}

/// One pixel's signal from its samples (at least one), mixed the way the sensor kind does.
PixelSignal mix_samples(Samples& samples, int ss, bool tof) {
  const std::size_t count = samples.count;
  const std::vector<double>& zs = samples.zs;
  const std::vector<double>& as = samples.as;
  std::vector<std::size_t>& order = samples.order;
  PixelSignal px;
  double sum_a = 0.0, sum_az = 0.0, zlo = kInf, zhi = -kInf;
  for (std::size_t i = 0; i < count; ++i) {
    sum_a += as[i];
    sum_az += as[i] * zs[i];
    zlo = std::min(zlo, zs[i]);
    zhi = std::max(zhi, zs[i]);
  }
  px.amplitude = sum_a / static_cast<double>(ss * ss);
  px.spread = zhi - zlo;
  if (tof) {
    // ToF mixes the returns of the footprint: amplitude-weighted depth (flying pixels).
    px.z = sum_a > 0.0 ? sum_az / sum_a : zs[0];
  } else {
    // Structured light matches a pattern window: the depth of one side (median sample).
    for (std::size_t i = 0; i < count; ++i) order[i] = i;
    std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(count / 2),
                     order.begin() + static_cast<std::ptrdiff_t>(count),
                     [&](std::size_t a, std::size_t b) { return zs[a] < zs[b]; });
    const std::size_t m = order[count / 2];
    px.z = zs[m];
    px.point = samples.points[m];
  }
  return px;
}

/// Ray casts each pixel's footprint (ss x ss rays), row by row, and mixes its samples; pixels
/// where no ray hits anything keep z = 0.
std::vector<PixelSignal> cast_pixels(const RayScene& rays, const Intrinsics& k, int ss, bool tof) {
  const int w = k.width, h = k.height;
  std::vector<PixelSignal> signal(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
  Samples samples(static_cast<std::size_t>(ss * ss));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      sample_footprint(rays, k, u, v, ss, samples);
      if (samples.count == 0) continue;
      signal[static_cast<std::size_t>(v * w + u)] = mix_samples(samples, ss, tof);
    }
  return signal;
}

/// The multipath bias [m] of each pixel when the profile (ToF) and the options have multipath;
/// empty otherwise.
std::vector<float> multipath_of(const std::vector<PixelSignal>& signal, const SensorProfile& profile,
                                const RenderOptions& opt) {
  std::vector<float> bias;
  const bool tof = profile.kind == SensorKind::kTimeOfFlight;
  if (tof && opt.multipath && profile.multipath_bias_m > 0.0) {
    std::vector<float> zf(signal.size());
    for (std::size_t i = 0; i < signal.size(); ++i) zf[i] = static_cast<float>(signal[i].z);
    bias = multipath_bias(zf, profile.intrinsics.width, profile.intrinsics.height, profile);
  }
  return bias;
}

/// The frame's fields other than its pixels; depth and intensity all 0.
void init_frame(Frame& frame, const Scene& scene, const SensorProfile& profile) {
  const Intrinsics& k = profile.intrinsics;
  const std::size_t n = static_cast<std::size_t>(k.width) * static_cast<std::size_t>(k.height);
  frame.intrinsics = k;
  frame.depth_scale_m = profile.depth_scale_m;
  frame.depth.assign(n, 0);
  frame.intensity.assign(n, 0);
  frame.intensity_bits = profile.intensity_bits;
  frame.T_base_camera = scene.T_world_camera;
  frame.camera_id = profile.camera_id;
}

/// What the sensor makes of one pixel's signal, given the frame's random numbers for it.
class SensorModel {
 public:
  SensorModel(const SensorProfile& profile, const RenderOptions& opt, const RayScene& rays, double p_invalid)
      : profile_(profile),
        opt_(opt),
        boxes_(rays.boxes),
        tof_(profile.kind == SensorKind::kTimeOfFlight),
        stereo_(profile.kind == SensorKind::kActiveStereo),
        p_invalid_(p_invalid),
        a_ref_(profile.reference_reflectance / (kReferenceRange_m * kReferenceRange_m)),
        projector_(rays.origin + rays.rotation * Eigen::Vector3d(profile.sl_baseline_m, 0.0, 0.0)),
        full_scale_(profile.intensity_bits == 8 ? 255.0 : 65535.0) {}

  /// Intensity: reflectance, incidence and 1/r^2 falloff, with noise (`g_int`: standard normal).
  [[nodiscard]] std::uint16_t intensity(const PixelSignal& px, double g_int) const {
    double value = px.amplitude / a_ref_ * profile_.intensity_ref * full_scale_;
    if (opt_.noise) {
      value += g_int * opt_.noise_scale *
               (profile_.intensity_noise_rel * value + kIntensityNoiseFloor * full_scale_);
    }
    return static_cast<std::uint16_t>(std::clamp(std::lround(value), 0L, static_cast<long>(full_scale_)));
  }

  /// Measured depth Z [m] of pixel (u, v) (`g_depth`: standard normal). ToF: multipath bias and
  /// noise along the ray; structured light: noise, then the disparity quantisation.
  [[nodiscard]] double depth(const PixelSignal& px, int u, int v, double g_depth, double bias_m) const {
    const Intrinsics& k = profile_.intrinsics;
    double z = px.z;
    const double ray_len = std::sqrt(1.0 + std::pow((u - k.cx) / k.fx, 2) + std::pow((v - k.cy) / k.fy, 2));
    if (tof_) {
      double along_ray = bias_m;
      if (opt_.noise) {
        along_ray += g_depth * opt_.noise_scale * profile_.tof_sigma_2m_m * std::sqrt(a_ref_ / px.amplitude);
      }
      z += along_ray / ray_len;  // range r -> Z = r / |ray|
    } else if (stereo_) {
      if (opt_.noise) z += g_depth * opt_.noise_scale * stereo_sigma_m(profile_, z);  // 1 mm output steps only
    } else if (opt_.noise) {
      z += g_depth * opt_.noise_scale * sl_sigma_m(profile_, z);
      const double fb = k.fx * profile_.sl_baseline_m;
      const double disparity =
          std::round(fb / z / profile_.sl_disparity_step_px) * profile_.sl_disparity_step_px;
      z = disparity > 0.0 ? fb / disparity : 0.0;
    }
    return z;
  }

  /// Whether the pixel is dropped (options.invalid): a random dropout (`dropout` below the frame's
  /// rate), too weak a return, and for structured light an edge without pattern match
  /// (`edge_roll`) or a point the projector does not light; for active stereo a point the second
  /// imager does not see (the same shadow test from its centre). Rolls are uniform in [0, 1).
  [[nodiscard]] bool dropped(const PixelSignal& px, double dropout, double edge_roll) const {
    if (dropout < p_invalid_) return true;
    if (px.amplitude < profile_.min_amplitude_rel * a_ref_) return true;
    if (tof_) return false;
    // No pattern match across an edge.
    if (!stereo_ && px.spread > kEdgeSpread_m && edge_roll < kEdgeDropChance) return true;
    const Eigen::Vector3d d = projector_ - px.point;
    for (const PreparedBox& b : boxes_)
      if (b.zmax > px.point.z() + kShadowClearance_m && detail::blocks_segment(b, px.point, d, kShadowTMin)) {
        return true;  // the projector does not light this point
      }
    return false;
  }

 private:
  const SensorProfile& profile_;
  const RenderOptions& opt_;
  const std::vector<PreparedBox>& boxes_;
  bool tof_;
  bool stereo_;
  double p_invalid_;           ///< dropout rate of this frame
  double a_ref_;               ///< amplitude of the reference surface [1/m^2]
  Eigen::Vector3d projector_;  ///< SL projector centre, world [m]
  double full_scale_;          ///< largest intensity value
};

/// Applies the sensor to the mixed signal, pixel by pixel in row-major order. Whatever happens to
/// a pixel, it draws its depth noise, intensity noise, dropout roll and edge roll, in that order,
/// after the frame's dropout rate: the frames of a seed depend on this order.
void apply_sensor(Frame& frame, const std::vector<PixelSignal>& signal, const std::vector<float>& bias,
                  const RayScene& rays, const SensorProfile& profile, std::uint64_t seed,
                  const RenderOptions& opt) {
  Rng noise_rng(seed, 1), invalid_rng(seed, 2), intensity_rng(seed, 3);
  const double p_invalid = opt.invalid ? invalid_rng.uniform(profile.invalid_min, profile.invalid_max) : 0.0;
  const SensorModel sensor(profile, opt, rays, p_invalid);
  const int w = profile.intrinsics.width, h = profile.intrinsics.height;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * w + u);
      const PixelSignal& px = signal[i];
      const double g_depth = noise_rng.normal();
      const double g_int = intensity_rng.normal();
      const double dropout = invalid_rng.uniform();
      const double edge_roll = invalid_rng.uniform();
      frame.intensity[i] = sensor.intensity(px, g_int);
      if (px.z <= 0.0) continue;
      const double z = sensor.depth(px, u, v, g_depth, bias.empty() ? 0.0 : bias[i]);
      if (opt.invalid && sensor.dropped(px, dropout, edge_roll)) continue;
      if (z < profile.min_range_m || z > profile.max_range_m) continue;
      const long raw = std::lround(z / profile.depth_scale_m);
      frame.depth[i] = static_cast<std::uint16_t>(std::clamp(raw, 1L, 65535L));
    }
}

/// Active stereo: each pixel reports the surface its matching window locks on (see
/// detail::stereo_sources); its own amplitude stays (the IR image is not matched).
std::vector<PixelSignal> match_windows(const std::vector<PixelSignal>& signal, const SensorProfile& profile,
                                       std::uint64_t seed) {
  std::vector<double> z(signal.size());
  for (std::size_t i = 0; i < signal.size(); ++i) z[i] = signal[i].z;
  Rng window_rng(seed, 4);
  const std::vector<std::size_t> source = detail::stereo_sources(z, profile.intrinsics.width, profile.intrinsics.height,
                                                                 profile.stereo_fattening_px, window_rng);
  std::vector<PixelSignal> matched = signal;
  for (std::size_t i = 0; i < signal.size(); ++i) {
    if (source[i] == i) continue;
    matched[i] = signal[source[i]];
    matched[i].amplitude = signal[i].amplitude;
  }
  return matched;
}

}  // namespace

/// Ray casts the scene, mixes each pixel's samples, then applies the sensor (multipath, noise,
/// dropouts, quantisation); the truth and the scene go with the frame.
SimulatedFrame render(const Scene& scene, const SensorProfile& profile, std::uint64_t seed, const RenderOptions& opt) {
  const int ss = std::max(1, opt.supersampling > 0 ? opt.supersampling : profile.supersampling);
  const bool tof = profile.kind == SensorKind::kTimeOfFlight;
  const RayScene rays = prepare_rays(scene, profile.intrinsics);
  std::vector<PixelSignal> signal = cast_pixels(rays, profile.intrinsics, ss, tof);
  if (profile.kind == SensorKind::kActiveStereo) signal = match_windows(signal, profile, seed);
  const std::vector<float> bias = multipath_of(signal, profile, opt);

  SimulatedFrame out;
  init_frame(out.frame, scene, profile);
  apply_sensor(out.frame, signal, bias, rays, profile, seed, opt);
  out.truth = make_truth(scene);
  out.scene = scene;
  return out;
}

}  // namespace palletd::sim
