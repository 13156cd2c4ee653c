// Seam evidence: gaps between boxes as depth below the plane, missing depth or dark intensity lines,
// resampled into a raster in the layer frame.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "layer_raster.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

namespace {

double median_abs_deviation(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  const double med = *mid;
  for (double& x : v) x = std::abs(x - med);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// How much darker pixel (u, v) is than both pixels r = 1 or 2 away on either side of it, across
/// a line along the row, the column or a diagonal (the largest of the eight) [intensity counts];
/// 0 where it is not darker than both, and within two pixels of the image border. A gap between
/// boxes is a dark line in the amplitude image (the gap returns less light than the tops on
/// either side of it); a step (a label, print, tape, a box of another shade) is darker on one
/// side only and gives nothing, where an edge detector answers both alike and draws seams along
/// every label.
float dark_line_depth(const std::vector<std::uint16_t>& inten, int width, int height, int u, int v) {
  constexpr int kAcross[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  constexpr int kReach = 2;  // pixels
  if (u < kReach || v < kReach || u >= width - kReach || v >= height - kReach) return 0.f;
  const auto at = [&](int x, int y) {
    return static_cast<float>(inten[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)]);
  };
  const float c = at(u, v);
  float best = 0.f;
  for (const auto& d : kAcross) {
    for (int r = 1; r <= kReach; ++r) {
      best = std::max(best, std::min(at(u + r * d[0], v + r * d[1]), at(u - r * d[0], v - r * d[1])) - c);
    }
  }
  return best;
}

/// Whether pixel (u, v), without depth, returned as much light as the layer's tops around it:
/// its intensity at least kBrightDropout of the median over the pixels within two of it whose
/// depth lies on the plane (within band_m). A gap returns little light; a pixel left without
/// depth on a bright top is a specular glint, saturation or a random dropout, not a seam.
/// False without such neighbours.
bool bright_dropout(const std::vector<std::uint16_t>& inten, const OrganizedCloud& cloud, const Plane& plane,
                    double band_m, int u, int v) {
  constexpr double kBrightDropout = 0.9;
  constexpr int kReach = 2;  // pixels
  std::vector<float> tops;
  for (int y = std::max(0, v - kReach); y <= std::min(cloud.height - 1, v + kReach); ++y) {
    for (int x = std::max(0, u - kReach); x <= std::min(cloud.width - 1, u + kReach); ++x) {
      const Eigen::Vector3f& p = cloud.at(x, y);
      if (!std::isfinite(p.x()) || !std::isfinite(p.z())) continue;
      if (std::abs(plane.signed_distance(p.cast<double>())) > band_m) continue;
      tops.push_back(static_cast<float>(inten[static_cast<std::size_t>(y) * static_cast<std::size_t>(cloud.width) + static_cast<std::size_t>(x)]));
    }
  }
  if (tops.size() < 3) return false;
  const auto mid = tops.begin() + static_cast<long>(tops.size() / 2);
  std::nth_element(tops.begin(), mid, tops.end());
  const float own = static_cast<float>(inten[static_cast<std::size_t>(v) * static_cast<std::size_t>(cloud.width) + static_cast<std::size_t>(u)]);
  return own >= kBrightDropout * *mid;
}

}  // namespace

SeamEvidence build_seam_evidence(const Frame& frame, const OrganizedCloud& cloud,
                                 const LayerResult& layer, const SeamParams& params) {
  SeamEvidence ev;
  const Intrinsics& in = frame.intrinsics;
  if (layer.status != DetectionStatus::ok || layer.polygons.empty() || !in.valid() ||
      cloud.width != in.width || cloud.height != in.height ||
      cloud.points.size() != frame.pixel_count()) {
    return ev;
  }
  const Plane& plane = layer.plane_camera;
  const double pitch = layout_detail::layer_pixel_pitch_m(in, layer);
  const auto geo = layout_detail::layer_raster_geometry(
      in, layer, params.cell_m > 0 ? params.cell_m : std::clamp(pitch, 0.001, 0.01), 0.02);
  if (!geo) return ev;
  ev.cell_m = geo->cell_m;
  ev.origin_m = geo->origin_m;
  ev.width = geo->width;
  ev.height = geo->height;
  const auto W = static_cast<std::size_t>(ev.width);
  // Only the inside of the outline counts: the outline itself is no seam.
  std::vector<std::uint8_t> mask_cells(W * static_cast<std::size_t>(ev.height), 0);
  cv::Mat mask(ev.height, ev.width, CV_8U, mask_cells.data());  // a view of mask_cells
  auto to_pts = [&](const Ring2d& ring) {
    std::vector<cv::Point> pts;
    for (const auto& p : ring) {
      pts.emplace_back(static_cast<int>(std::lround((p.x() - ev.origin_m.x()) / ev.cell_m * 16.0 - 8.0)),
                       static_cast<int>(std::lround((p.y() - ev.origin_m.y()) / ev.cell_m * 16.0 - 8.0)));
    }
    return pts;
  };
  for (const auto& poly : layer.polygons) {
    std::vector<std::vector<cv::Point>> outer{to_pts(poly.outer)};
    cv::fillPoly(mask, outer, cv::Scalar(1), cv::LINE_8, 4);
    std::vector<std::vector<cv::Point>> holes;
    for (const auto& h : poly.holes) holes.push_back(to_pts(h));
    if (!holes.empty()) cv::fillPoly(mask, holes, cv::Scalar(0), cv::LINE_8, 4);
  }
  // Cells on the outline mix box tops with the floor around: keep two cells clear of it.
  layout_detail::erode_square(mask_cells, ev.width, ev.height, 2);

  // Pass 1: which pixels fall inside the layer, and the noise of depth and intensity there.
  std::vector<int> cell_of(frame.pixel_count(), -1);
  for (int v = 0; v < in.height; ++v) {
    for (int u = 0; u < in.width; ++u) {
      double fx = 0.0, fy = 0.0;
      if (!geo->cell_of(u, v, &fx, &fy)) continue;
      const int cx = static_cast<int>(fx);
      const int cy = static_cast<int>(fy);
      cell_of[static_cast<std::size_t>(v) * static_cast<std::size_t>(in.width) + static_cast<std::size_t>(u)] =
          cy * ev.width + cx;
    }
  }
  std::vector<double> residuals;
  for (std::size_t pix = 0; pix < cell_of.size(); ++pix) {
    const int c = cell_of[pix];
    if (c < 0 || mask_cells[static_cast<std::size_t>(c)] == 0) continue;
    const Eigen::Vector3f& p = cloud.points[pix];
    if (std::isfinite(p.x()) && std::isfinite(p.z())) residuals.push_back(plane.signed_distance(p.cast<double>()));
  }
  // Depth noise: the layer stage's plane residual when it reports one, else a robust estimate
  // (MAD) of the residuals on the layer. A pixel is seam-like only when it lies clearly below
  // the plane against that noise (seams, not noise, reach several sigma).
  double sigma_m = layer.diagnostics.plane_sigma_m;
  if (!(sigma_m > 0.0) && residuals.size() >= 20) sigma_m = 1.4826 * median_abs_deviation(residuals);
  const double step = std::max(params.depth_step_m, params.depth_noise_k * (std::isfinite(sigma_m) ? sigma_m : 0.0));
  ev.depth_threshold_m = step;

  // Dark lines in the intensity image, against the intensity noise on the layer (from the MAD of
  // neighbouring pixels' differences, which the tops' shading does not reach).
  double intensity_sigma = 0.0;
  if (frame.has_intensity() && params.intensity_weight > 0 && frame.intensity.size() == frame.pixel_count()) {
    std::vector<double> diffs;
    const auto width = static_cast<std::size_t>(in.width);
    for (std::size_t pix = 0; pix + 1 < cell_of.size(); ++pix) {
      const int c = cell_of[pix];
      if (c < 0 || cell_of[pix + 1] < 0 || (pix + 1) % width == 0) continue;
      if (mask_cells[static_cast<std::size_t>(c)] == 0) continue;
      diffs.push_back(static_cast<double>(frame.intensity[pix + 1]) - static_cast<double>(frame.intensity[pix]));
    }
    if (diffs.size() >= 20) {
      // A floor of one count keeps noise-free (synthetic) intensity from dividing by zero.
      intensity_sigma = std::max(1.4826 * median_abs_deviation(std::move(diffs)) / std::sqrt(2.0), 1.0);
    }
  }

  std::vector<float> sum(W * static_cast<std::size_t>(ev.height), 0.f), count(sum.size(), 0.f);
  const double g_lo = params.intensity_noise_k;
  for (std::size_t pix = 0; pix < cell_of.size(); ++pix) {
    const int cell = cell_of[pix];
    if (cell < 0) continue;
    const Eigen::Vector3f& p = cloud.points[pix];
    const int u = static_cast<int>(pix % static_cast<std::size_t>(in.width));
    const int v = static_cast<int>(pix / static_cast<std::size_t>(in.width));
    float s;
    if (!std::isfinite(p.x()) || !std::isfinite(p.z())) {
      // No measurement: a gap or a dark edge, or a random dropout. The layout stage keeps only
      // line-like runs of these along its axes (SeamTable), so scattered dropouts fade. Where
      // the intensity shows the pixel as bright as the tops around it, it is no gap.
      s = intensity_sigma > 0 && bright_dropout(frame.intensity, cloud, plane, step, u, v) ? 0.f : 1.f;
    } else {
      const double below = -plane.signed_distance(p.cast<double>());
      s = static_cast<float>(std::clamp((below - step) / step, 0.0, 1.0));
    }
    if (intensity_sigma > 0) {
      const double z = dark_line_depth(frame.intensity, in.width, in.height, u, v) / intensity_sigma;
      s = std::max(s, static_cast<float>(params.intensity_weight * std::clamp((z - g_lo) / g_lo, 0.0, 1.0)));
    }
    const auto c = static_cast<std::size_t>(cell);
    sum[c] += s;
    count[c] += 1.f;
  }
  // Mean per cell; cells no pixel fell into take their neighbours' mean.
  cv::Mat msum(ev.height, ev.width, CV_32F, sum.data()), mcount(ev.height, ev.width, CV_32F, count.data());
  cv::Mat nsum, ncount;
  cv::boxFilter(msum, nsum, CV_32F, cv::Size(3, 3), cv::Point(-1, -1), false);
  cv::boxFilter(mcount, ncount, CV_32F, cv::Size(3, 3), cv::Point(-1, -1), false);
  ev.seam.assign(sum.size(), 0.f);
  std::size_t inside = 0, seamy = 0;
  for (int y = 0; y < ev.height; ++y) {
    for (int x = 0; x < ev.width; ++x) {
      const std::size_t c = static_cast<std::size_t>(y) * W + static_cast<std::size_t>(x);
      if (mask_cells[c] == 0) continue;
      float s = 0.f;
      if (count[c] > 0) {
        s = sum[c] / count[c];
      } else if (ncount.at<float>(y, x) > 0) {
        s = nsum.at<float>(y, x) / ncount.at<float>(y, x);
      }
      ev.seam[c] = s;
      ++inside;
      if (s > 0.5f) ++seamy;
    }
  }
  ev.strength = inside > 0 ? static_cast<double>(seamy) / static_cast<double>(inside) : 0.0;
  return ev;
}

}  // namespace palletd
