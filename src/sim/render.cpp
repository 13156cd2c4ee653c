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

}  // namespace

SimulatedFrame render(const Scene& scene, const SensorProfile& profile, std::uint64_t seed, const RenderOptions& opt) {
  const Intrinsics& k = profile.intrinsics;
  const int w = k.width, h = k.height;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  const int ss = std::max(1, opt.supersampling > 0 ? opt.supersampling : profile.supersampling);
  const bool tof = profile.kind == SensorKind::TimeOfFlight;

  std::vector<PreparedBox> boxes;
  boxes.reserve(scene.boxes.size());
  for (const SimBox& b : scene.boxes) boxes.push_back(detail::prepare(b));
  const Eigen::Matrix3d R = scene.T_world_camera.linear();
  const Eigen::Vector3d o = scene.T_world_camera.translation();
  const int tiles_x = (w + kTile - 1) / kTile, tiles_y = (h + kTile - 1) / kTile;
  const auto tiles = tile_lists(boxes, scene.T_world_camera.inverse(), k, tiles_x, tiles_y);

  std::vector<PixelSignal> signal(n);
  std::vector<double> zs(static_cast<std::size_t>(ss * ss)), as(zs.size());
  std::vector<Eigen::Vector3d> points(zs.size());
  std::vector<std::size_t> order(zs.size());
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const auto& list = tiles[static_cast<std::size_t>((v / kTile) * tiles_x + u / kTile)];
      std::size_t count = 0;
      for (int sy = 0; sy < ss; ++sy)
        for (int sx = 0; sx < ss; ++sx) {
          const double pu = u + (sx + 0.5) / ss - 0.5, pv = v + (sy + 0.5) / ss - 0.5;
          const Eigen::Vector3d dir_cam((pu - k.cx) / k.fx, (pv - k.cy) / k.fy, 1.0);
          const Eigen::Vector3d d = R * dir_cam;
          Hit best;
          best.t = kInf;
          if (d.z() < 0.0) {  // the floor, z = 0
            best.t = -o.z() / d.z();
            best.normal = Eigen::Vector3d::UnitZ();
            best.reflectance = scene.floor_reflectance;
          }
          double hit_z = d.z() < 0.0 ? 0.0 : -kInf;  // height of the nearest hit so far
          for (int bi : list) {
            const PreparedBox& box = boxes[static_cast<std::size_t>(bi)];
            // A downward ray reaches a box lower than its current hit only after that hit; the
            // list is sorted by height, so no later box can be nearer.
            if (box.zmax < hit_z) break;
            Hit hit;
            if (detail::intersect(box, o, d, 1e-6, best.t, hit)) {
              best = hit;
              hit_z = o.z() + best.t * d.z();
            }
          }
          if (!std::isfinite(best.t)) continue;
          const double len = dir_cam.norm();
          const double range = best.t * len;
          const double cos_inc = std::abs(best.normal.dot(d)) / len;
          zs[count] = best.t;  // t is the camera Z because dir_cam.z = 1
          as[count] = best.reflectance * cos_inc / (range * range);
          points[count] = o + best.t * d;
          ++count;
        }
      if (count == 0) continue;
      PixelSignal& px = signal[static_cast<std::size_t>(v * w + u)];
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
        px.point = points[m];
      }
    }

  std::vector<float> bias;
  if (tof && opt.multipath && profile.multipath_bias_m > 0.0) {
    std::vector<float> zf(n);
    for (std::size_t i = 0; i < n; ++i) zf[i] = static_cast<float>(signal[i].z);
    bias = multipath_bias(zf, w, h, profile);
  }

  Rng noise_rng(seed, 1), invalid_rng(seed, 2), intensity_rng(seed, 3);
  const double p_invalid = opt.invalid ? invalid_rng.uniform(profile.invalid_min, profile.invalid_max) : 0.0;
  const double a_ref = profile.reference_reflectance / 4.0;  // reference surface at 2 m
  const Eigen::Vector3d projector = o + R * Eigen::Vector3d(profile.sl_baseline_m, 0.0, 0.0);
  const double full_scale = profile.intensity_bits == 8 ? 255.0 : 65535.0;

  SimulatedFrame out;
  Frame& frame = out.frame;
  frame.intrinsics = k;
  frame.depth_scale_m = profile.depth_scale_m;
  frame.depth.assign(n, 0);
  frame.intensity.assign(n, 0);
  frame.intensity_bits = profile.intensity_bits;
  frame.T_base_camera = scene.T_world_camera;
  frame.camera_id = profile.camera_id;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * w + u);
      const PixelSignal& px = signal[i];
      const double g_depth = noise_rng.normal();
      const double g_int = intensity_rng.normal();
      const double dropout = invalid_rng.uniform();
      const double edge_roll = invalid_rng.uniform();
      // Intensity: reflectance, incidence and 1/r^2 falloff, with noise.
      double value = px.amplitude / a_ref * profile.intensity_ref * full_scale;
      if (opt.noise) value += g_int * opt.noise_scale * (profile.intensity_noise_rel * value + 0.0001 * full_scale);
      frame.intensity[i] = static_cast<std::uint16_t>(std::clamp(std::lround(value), 0L, static_cast<long>(full_scale)));
      if (px.z <= 0.0) continue;
      double z = px.z;
      const double ray_len = std::sqrt(1.0 + std::pow((u - k.cx) / k.fx, 2) + std::pow((v - k.cy) / k.fy, 2));
      if (tof) {
        double along_ray = bias.empty() ? 0.0 : bias[i];
        if (opt.noise) along_ray += g_depth * opt.noise_scale * profile.tof_sigma_2m_m * std::sqrt(a_ref / px.amplitude);
        z += along_ray / ray_len;  // range r -> Z = r / |ray|
      } else if (opt.noise) {
        z += g_depth * opt.noise_scale * sl_sigma_m(profile, z);
        const double fb = k.fx * profile.sl_baseline_m;
        const double disparity = std::round(fb / z / profile.sl_disparity_step_px) * profile.sl_disparity_step_px;
        z = disparity > 0.0 ? fb / disparity : 0.0;
      }
      if (opt.invalid) {
        if (dropout < p_invalid) continue;
        if (px.amplitude < profile.min_amplitude_rel * a_ref) continue;
        if (!tof) {
          if (px.spread > 0.02 && edge_roll < 0.5) continue;  // no pattern match across an edge
          const Eigen::Vector3d d = projector - px.point;
          bool shadow = false;
          for (const PreparedBox& b : boxes)
            if (b.zmax > px.point.z() + 1e-3 && detail::blocks_segment(b, px.point, d, 1e-3)) {
              shadow = true;
              break;
            }
          if (shadow) continue;  // the projector does not light this point
        }
      }
      if (z < profile.min_range_m || z > profile.max_range_m) continue;
      const long raw = std::lround(z / profile.depth_scale_m);
      frame.depth[i] = static_cast<std::uint16_t>(std::clamp(raw, 1L, 65535L));
    }
  out.truth = make_truth(scene);
  out.scene = scene;
  return out;
}

}  // namespace palletd::sim
