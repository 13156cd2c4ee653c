// intensity_edge_offset(): the intensity step across the layer's outline against the outline.
#include "edge_offset.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "palletd/core/statistics.hpp"

#include "layer_raster.hpp"

namespace palletd {

namespace {

constexpr int kSteps = 8;             ///< profile samples either side of the outline
constexpr double kStep_px = 0.5;      ///< between profile samples [pixel pitches]
constexpr int kEnd = 3;               ///< samples averaged at each end of a profile
constexpr double kCornerShare = 0.2;  ///< of each outline side left out at either end
constexpr double kMinSide_px = 6.0;   ///< shorter outline sides are not sampled [pixel pitches]
constexpr double kMinContrast = 0.1;  ///< |inside - outside| / the brighter, for a clear step

/// A point on the outline and the outward normal there, layer frame.
struct OutlineSample {
  Eigen::Vector2d at_m;
  Eigen::Vector2d out;
};

/// Samples along the outer rings (counter-clockwise: outward is to the right of each side).
std::vector<OutlineSample> outline_samples(const LayerResult& layer, double pitch_m) {
  std::vector<OutlineSample> samples;
  for (const PolygonWithHoles& polygon : layer.polygons) {
    const Ring2d& ring = polygon.outer;
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const Eigen::Vector2d a = ring[i], b = ring[(i + 1) % ring.size()];
      const double length_m = (b - a).norm();
      if (length_m < kMinSide_px * pitch_m) continue;
      const Eigen::Vector2d along = (b - a) / length_m;
      for (double t = kCornerShare * length_m; t <= (1.0 - kCornerShare) * length_m; t += pitch_m)
        samples.push_back({a + t * along, Eigen::Vector2d(along.y(), -along.x())});
    }
  }
  return samples;
}

/// Intensity at a sub-pixel position (bilinear); NaN outside the image.
double intensity_at(const Frame& frame, const cv::Point2f& p) {
  const Intrinsics& in = frame.intrinsics;
  const double u = p.x, v = p.y;
  if (!(u >= 0.0 && v >= 0.0 && u < in.width - 1 && v < in.height - 1)) return std::nan("");
  const int u0 = static_cast<int>(u), v0 = static_cast<int>(v);
  const double fu = u - u0, fv = v - v0;
  const auto at = [&](int x, int y) {
    return static_cast<double>(
        frame.intensity[static_cast<std::size_t>(y) * static_cast<std::size_t>(in.width) +
                        static_cast<std::size_t>(x)]);
  };
  return (1 - fv) * ((1 - fu) * at(u0, v0) + fu * at(u0 + 1, v0)) +
         fv * ((1 - fu) * at(u0, v0 + 1) + fu * at(u0 + 1, v0 + 1));
}

/// Where across one profile (in steps from the outline, + outwards) the intensity steps, or NaN
/// where it does not step clearly.
double step_position(const std::vector<double>& values) {
  const auto n = static_cast<int>(values.size());
  double inside = 0.0, outside = 0.0;
  for (int k = 0; k < kEnd; ++k) {
    inside += values[static_cast<std::size_t>(k)] / kEnd;
    outside += values[static_cast<std::size_t>(n - 1 - k)] / kEnd;
  }
  if (!(std::abs(inside - outside) >= kMinContrast * std::max(inside, outside))) return std::nan("");
  const double sign = outside > inside ? 1.0 : -1.0;
  std::vector<double> rise(values.size(), -1e300);
  for (int k = 1; k + 1 < n; ++k)
    rise[static_cast<std::size_t>(k)] =
        sign * (values[static_cast<std::size_t>(k + 1)] - values[static_cast<std::size_t>(k - 1)]);
  const auto peak = static_cast<int>(std::max_element(rise.begin(), rise.end()) - rise.begin());
  double sub = 0.0;  // the peak between samples: a parabola through it and its neighbours
  if (peak > 1 && peak < n - 2) {
    const double l = rise[static_cast<std::size_t>(peak - 1)], c = rise[static_cast<std::size_t>(peak)],
                 r = rise[static_cast<std::size_t>(peak + 1)];
    const double curvature = l - 2 * c + r;
    if (curvature < 0.0) sub = std::clamp(0.5 * (l - r) / curvature, -0.5, 0.5);
  }
  return peak + sub - kSteps;
}

/// A side faces away from the camera (or towards it) when its outward normal makes at least this
/// cosine with the direction from the camera's foot on the layer to the layer (or its opposite).
constexpr double kFacingCos = 0.5;
/// The most the outline is moved towards the camera: this share of the median offset.
constexpr double kMaxShiftShare = 0.5;

/// An outline sample where the intensity steps clearly: how far inside the outline [m].
struct EdgeStep {
  Eigen::Vector2d at_m;
  Eigen::Vector2d out;
  double offset_m = 0.0;
};

/// The offsets of the sides facing away from the camera and of those facing it, fitted as
/// offset = inset + b (n . u), u the direction from the camera's foot point to the samples' middle:
/// b from the two groups' medians at their mean cosines, the inset the median of what is left
/// over every sample. The sides facing the camera are fattened less, not negatively: a group
/// whose median lies outside the outline has found another step (a wall's foot, the floor), and
/// the facing is not used. The shift is at most half the median offset.
void fit_facing(const std::vector<EdgeStep>& steps, const Eigen::Vector2d& foot_m, std::size_t min_samples,
                EdgeOffset& edges) {
  edges.inset_m = edges.offset_m;
  Eigen::Vector2d middle = Eigen::Vector2d::Zero();
  for (const EdgeStep& s : steps) middle += s.at_m / static_cast<double>(steps.size());
  const Eigen::Vector2d away = middle - foot_m;
  if (!(away.norm() > 0.0) || !(edges.offset_m > 0.0)) return;
  const Eigen::Vector2d u = away.normalized();
  std::vector<double> far_m, near_m;
  double far_cos = 0.0, near_cos = 0.0;
  for (const EdgeStep& s : steps) {
    const double c = s.out.dot(u);
    if (c >= kFacingCos) {
      far_m.push_back(s.offset_m);
      far_cos += c;
    } else if (c <= -kFacingCos) {
      near_m.push_back(s.offset_m);
      near_cos += c;
    }
  }
  if (far_m.size() < min_samples || near_m.size() < min_samples) return;
  far_cos /= static_cast<double>(far_m.size());
  near_cos /= static_cast<double>(near_m.size());
  const double far = upper_median(std::move(far_m)), near = upper_median(std::move(near_m));
  if (!(near >= 0.0 && far >= 0.0)) return;
  const double bound = kMaxShiftShare * edges.offset_m;
  const double b = std::clamp((far - near) / (far_cos - near_cos), -bound, bound);
  std::vector<double> left;
  for (const EdgeStep& s : steps) left.push_back(s.offset_m - b * s.out.dot(u));
  edges.inset_m = upper_median(std::move(left));
  edges.shift_m = b * u;
}

}  // namespace

EdgeOffset intensity_edge_offset(const Frame& frame, const LayerResult& layer, std::size_t min_samples) {
  const Intrinsics& in = frame.intrinsics;
  if (!frame.has_intensity() || frame.intensity.size() != frame.pixel_count() || !in.valid() ||
      layer.status != DetectionStatus::kOk)
    return {};
  const double pitch_m = layout_detail::layer_pixel_pitch_m(in, layer);
  if (!(pitch_m > 0.0)) return {};
  const std::vector<OutlineSample> samples = outline_samples(layer, pitch_m);
  std::vector<cv::Point3f> points_camera;
  for (const OutlineSample& s : samples) {
    for (int k = -kSteps; k <= kSteps; ++k) {
      const Eigen::Vector2d p = s.at_m + k * kStep_px * pitch_m * s.out;
      const Eigen::Vector3d c = layer.T_camera_layer * Eigen::Vector3d(p.x(), p.y(), 0.0);
      points_camera.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                 static_cast<float>(c.z()));
    }
  }
  if (points_camera.empty()) return {};
  const cv::Matx33d K(in.fx, 0.0, in.cx, 0.0, in.fy, in.cy, 0.0, 0.0, 1.0);
  cv::Mat distortion;
  if (in.distortion)
    distortion = cv::Mat(std::vector<double>(in.distortion->begin(), in.distortion->end()), true);
  std::vector<cv::Point2f> pixels;
  cv::projectPoints(points_camera, cv::Vec3d::zeros(), cv::Vec3d::zeros(), K, distortion, pixels);

  std::vector<double> values(2 * kSteps + 1);
  std::vector<EdgeStep> steps;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    bool seen = true;
    for (std::size_t k = 0; k < values.size() && seen; ++k) {
      values[k] = intensity_at(frame, pixels[i * values.size() + k]);
      seen = std::isfinite(values[k]);
    }
    if (!seen) continue;
    const double at_steps = step_position(values);
    if (!std::isfinite(at_steps)) continue;
    steps.push_back({samples[i].at_m, samples[i].out, -at_steps * kStep_px * pitch_m});
  }
  if (steps.size() < min_samples) return {};
  std::vector<double> offsets_m;
  for (const EdgeStep& s : steps) offsets_m.push_back(s.offset_m);
  EdgeOffset edges;
  edges.samples = steps.size();
  edges.offset_m = upper_median(std::move(offsets_m));
  const Eigen::Vector2d foot_m = (layer.T_camera_layer.inverse() * Eigen::Vector3d::Zero()).head<2>();
  fit_facing(steps, foot_m, min_samples, edges);
  return edges;
}

}  // namespace palletd
