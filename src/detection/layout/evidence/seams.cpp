// Seam evidence: gaps between boxes as depth below the plane, missing depth or dark intensity lines,
// resampled into a raster in the layer frame.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/core/statistics.hpp"
#include "palletd/detection/layout.hpp"

#include "layer_raster.hpp"

namespace palletd {

namespace {

/// Raster cell: the layer's pixel pitch within these bounds, unless SeamParams::cell_m sets it [m].
constexpr double kMinCell_m = 0.001;
constexpr double kMaxCell_m = 0.01;
/// The raster covers the layer's outer rings grown by this on each side [m].
constexpr double kRasterMargin_m = 0.02;
/// Fixed-point vertices for cv::fillPoly: this many fraction bits.
constexpr int kFillShift = 4;
constexpr double kFillScale = static_cast<double>(1 << kFillShift);
/// Cells within this many of the outline are left out: they mix box tops with the floor around.
constexpr int kOutlineClearance_cells = 2;
/// Fewest residuals (or intensity differences) for a robust noise estimate.
constexpr std::size_t kMinNoiseSamples = 20;
/// Robust sigma from a median absolute deviation (normal noise).
constexpr double kMadToSigma = 1.4826;
/// Smallest intensity noise [intensity counts]: keeps noise-free (synthetic) intensity from
/// dividing by zero.
constexpr double kMinIntensitySigma = 1.0;
/// A cell whose mean seam-likeness exceeds this counts as seam-like in SeamEvidence::strength.
constexpr float kSeamLike = 0.5f;

double median_abs_deviation(std::vector<double> v) {
  const double med = upper_median(v);
  for (double& x : v) x = std::abs(x - med);
  return upper_median(std::move(v));
}

/// For every pixel: how much darker it is than both pixels r = 1 or 2 away on either side of it,
/// across a line along the row, the column or a diagonal (the largest of the eight) [intensity
/// counts]; 0 where it is not darker than both, within two pixels of the image border and outside
/// `window` (the only pixels read). A gap
/// between boxes is a dark line in the amplitude image (the gap returns less light than the tops
/// on either side of it); a step (a label, print, tape, a box of another shade) is darker on one
/// side only and gives nothing, where an edge detector answers both alike and draws seams along
/// every label. Operations over the window on 16-bit counts: the subtraction saturates at 0.
cv::Mat dark_line_depths(const std::vector<std::uint16_t>& inten, int width, int height,
                         const layout_detail::PixelWindow& window) {
  constexpr int kAcross[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  constexpr int kReach = 2;  // pixels
  cv::Mat depths = cv::Mat::zeros(height, width, CV_16U);
  const cv::Rect inner = cv::Rect(kReach, kReach, width - 2 * kReach, height - 2 * kReach) &
                         cv::Rect(window.u0, window.v0, window.u1 - window.u0, window.v1 - window.v0);
  if (inner.empty()) return depths;
  const cv::Mat image(height, width, CV_16U, const_cast<std::uint16_t*>(inten.data()));  // read only
  const auto at = [&](int dx, int dy) { return image(inner + cv::Point(dx, dy)); };
  cv::Mat best = depths(inner);
  cv::Mat darker;
  for (const auto& d : kAcross) {
    for (int r = 1; r <= kReach; ++r) {
      cv::min(at(r * d[0], r * d[1]), at(-r * d[0], -r * d[1]), darker);
      cv::subtract(darker, at(0, 0), darker);
      cv::max(best, darker, best);
    }
  }
  return depths;
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
  std::array<float, (2 * kReach + 1) * (2 * kReach + 1)> tops{};
  std::size_t n = 0;
  for (int y = std::max(0, v - kReach); y <= std::min(cloud.height - 1, v + kReach); ++y) {
    for (int x = std::max(0, u - kReach); x <= std::min(cloud.width - 1, u + kReach); ++x) {
      const Eigen::Vector3f& p = cloud.at(x, y);
      if (!std::isfinite(p.x()) || !std::isfinite(p.z())) continue;
      if (std::abs(plane.signed_distance(p.cast<double>())) > band_m) continue;
      tops[n++] =
          static_cast<float>(inten[static_cast<std::size_t>(y) * static_cast<std::size_t>(cloud.width) +
                                   static_cast<std::size_t>(x)]);
    }
  }
  if (n < 3) return false;
  const auto mid = tops.begin() + static_cast<long>(n / 2);
  std::nth_element(tops.begin(), mid, tops.begin() + static_cast<long>(n));
  const float own = static_cast<float>(inten[static_cast<std::size_t>(v) * static_cast<std::size_t>(cloud.width) + static_cast<std::size_t>(u)]);
  return own >= kBrightDropout * *mid;
}

/// A ring's vertices in fillPoly's fixed point on the raster (cell centres at index + 0.5).
std::vector<cv::Point> raster_points(const Ring2d& ring, const SeamEvidence& ev) {
  std::vector<cv::Point> pts;
  for (const auto& p : ring) {
    pts.emplace_back(
        static_cast<int>(std::lround((p.x() - ev.origin_m.x()) / ev.cell_m * kFillScale - 0.5 * kFillScale)),
        static_cast<int>(std::lround((p.y() - ev.origin_m.y()) / ev.cell_m * kFillScale - 0.5 * kFillScale)));
  }
  return pts;
}

/// The cells inside the layer's outline (1, else 0), eroded by kOutlineClearance_cells: only the
/// inside of the outline counts, the outline itself is no seam.
std::vector<std::uint8_t> inside_cells(const LayerResult& layer, const SeamEvidence& ev) {
  const std::size_t cells = static_cast<std::size_t>(ev.width) * static_cast<std::size_t>(ev.height);
  std::vector<std::uint8_t> mask_cells(cells, 0);
  cv::Mat mask(ev.height, ev.width, CV_8U, mask_cells.data());  // a view of mask_cells
  for (const auto& poly : layer.polygons) {
    std::vector<std::vector<cv::Point>> outer{raster_points(poly.outer, ev)};
    cv::fillPoly(mask, outer, cv::Scalar(1), cv::LINE_8, kFillShift);
    std::vector<std::vector<cv::Point>> holes;
    for (const auto& h : poly.holes) holes.push_back(raster_points(h, ev));
    if (!holes.empty()) cv::fillPoly(mask, holes, cv::Scalar(0), cv::LINE_8, kFillShift);
  }
  layout_detail::erode_square(mask_cells, ev.width, ev.height, kOutlineClearance_cells);
  return mask_cells;
}

/// The raster cell of each pixel (row-major), where its viewing ray meets the plane; -1 for a
/// pixel whose ray misses the raster.
std::vector<int> pixel_cells(const layout_detail::LayerRasterGeometry& geo, const Intrinsics& in,
                             const layout_detail::PixelWindow& window, std::size_t pixel_count) {
  std::vector<int> cell_of(pixel_count, -1);
  for (int v = window.v0; v < window.v1; ++v) {
    for (int u = window.u0; u < window.u1; ++u) {
      double fx = 0.0, fy = 0.0;
      if (!geo.cell_of(u, v, &fx, &fy)) continue;
      const int cx = static_cast<int>(fx);
      const int cy = static_cast<int>(fy);
      cell_of[static_cast<std::size_t>(v) * static_cast<std::size_t>(in.width) + static_cast<std::size_t>(u)] =
          cy * geo.width + cx;
    }
  }
  return cell_of;
}

/// Depth below the plane where seams start [m]: max(depth_step_m, depth_noise_k x sigma), sigma
/// the layer stage's plane residual when it reports one, else a robust estimate (MAD) of the
/// residuals of the pixels inside the mask. A pixel is seam-like only when it lies clearly below
/// the plane against that noise (seams, not noise, reach several sigma).
double seam_depth_step_m(const OrganizedCloud& cloud, const Plane& plane, const std::vector<int>& cell_of,
                         const std::vector<std::uint8_t>& mask_cells, const LayerResult& layer,
                         const SeamParams& params) {
  const auto step_for = [&](double sigma_m) {
    return std::max(params.depth_step_m, params.depth_noise_k * (std::isfinite(sigma_m) ? sigma_m : 0.0));
  };
  const double layer_sigma_m = layer.diagnostics.plane_sigma_m;
  if (layer_sigma_m > 0.0) return step_for(layer_sigma_m);
  std::vector<double> residuals;
  for (std::size_t pix = 0; pix < cell_of.size(); ++pix) {
    const int c = cell_of[pix];
    if (c < 0 || mask_cells[static_cast<std::size_t>(c)] == 0) continue;
    const Eigen::Vector3f& p = cloud.points[pix];
    if (std::isfinite(p.x()) && std::isfinite(p.z())) residuals.push_back(plane.signed_distance(p.cast<double>()));
  }
  if (residuals.size() < kMinNoiseSamples) return step_for(layer_sigma_m);
  return step_for(kMadToSigma * median_abs_deviation(std::move(residuals)));
}

/// The value at sorted index n / 2 of a histogram of `n` integers (counts[k] of value k - offset):
/// upper_median() of the values themselves.
int histogram_upper_median(const std::vector<std::uint32_t>& counts, int offset, std::size_t n) {
  std::size_t seen = 0;
  for (std::size_t k = 0; k < counts.size(); ++k) {
    seen += counts[k];
    if (seen > n / 2) return static_cast<int>(k) - offset;
  }
  return static_cast<int>(counts.size()) - 1 - offset;
}

/// The intensity noise on the layer [intensity counts], from the MAD of horizontally neighbouring
/// pixels' differences inside the mask (the tops' shading does not reach them); 0 when the
/// intensity is not used (none, weight 0, or too few differences). The differences are integers:
/// their median and MAD come from histograms.
double intensity_noise(const Frame& frame, const std::vector<int>& cell_of,
                       const std::vector<std::uint8_t>& mask_cells, const SeamParams& params) {
  const bool use_intensity = frame.has_intensity() && params.intensity_weight > 0 &&
                             frame.intensity.size() == frame.pixel_count();
  if (!use_intensity) return 0.0;
  constexpr int kOffset = 65535;  // differences of 16-bit counts lie in [-kOffset, kOffset]
  std::vector<std::uint32_t> diffs(2 * kOffset + 1, 0);
  std::size_t n = 0;
  const auto width = static_cast<std::size_t>(frame.intrinsics.width);
  for (std::size_t pix = 0; pix + 1 < cell_of.size(); ++pix) {
    const int c = cell_of[pix];
    if (c < 0 || cell_of[pix + 1] < 0 || (pix + 1) % width == 0) continue;
    if (mask_cells[static_cast<std::size_t>(c)] == 0) continue;
    ++diffs[static_cast<std::size_t>(int{frame.intensity[pix + 1]} - int{frame.intensity[pix]} + kOffset)];
    ++n;
  }
  if (n < kMinNoiseSamples) return 0.0;
  const int median = histogram_upper_median(diffs, kOffset, n);
  std::vector<std::uint32_t> deviations(2 * kOffset + 1, 0);
  for (std::size_t k = 0; k < diffs.size(); ++k)
    deviations[static_cast<std::size_t>(std::abs(static_cast<int>(k) - kOffset - median))] += diffs[k];
  const int mad = histogram_upper_median(deviations, 0, n);
  return std::max(kMadToSigma * mad / std::sqrt(2.0), kMinIntensitySigma);
}

/// What scoring a pixel's seam-likeness takes.
struct PixelScoring {
  const Frame& frame;
  const OrganizedCloud& cloud;
  const Plane& plane;
  const SeamParams& params;
  double step_m = 0.0;           ///< depth below the plane where seams start [m]
  double intensity_sigma = 0.0;  ///< intensity noise [counts]; 0: intensity not used
  cv::Mat dark_lines;            ///< dark_line_depths() of the intensity (CV_16U) when it is used
};

/// How seam-like pixel `pix` (at u, v) looks, 0..1: its depth below the plane (from step_m on,
/// fully at twice that), or without a measurement 1 (0 where it is a bright dropout); with the
/// intensity, at least intensity_weight x its dark line's depth (from intensity_noise_k sigmas
/// on, fully at twice that).
float pixel_seam(const PixelScoring& ps, std::size_t pix, int u, int v) {
  const Eigen::Vector3f& p = ps.cloud.points[pix];
  float s;
  if (!std::isfinite(p.x()) || !std::isfinite(p.z())) {
    // No measurement: a gap or a dark edge, or a random dropout. The layout stage keeps only
    // line-like runs of these along its axes (SeamTable), so scattered dropouts fade. Where
    // the intensity shows the pixel as bright as the tops around it, it is no gap.
    const bool bright = ps.intensity_sigma > 0 &&
                        bright_dropout(ps.frame.intensity, ps.cloud, ps.plane, ps.step_m, u, v);
    s = bright ? 0.f : 1.f;
  } else {
    const double below = -ps.plane.signed_distance(p.cast<double>());
    s = static_cast<float>(std::clamp((below - ps.step_m) / ps.step_m, 0.0, 1.0));
  }
  if (ps.intensity_sigma > 0) {
    const double g_lo = ps.params.intensity_noise_k;
    const double z = ps.dark_lines.at<std::uint16_t>(v, u) / ps.intensity_sigma;
    s = std::max(s, static_cast<float>(ps.params.intensity_weight * std::clamp((z - g_lo) / g_lo, 0.0, 1.0)));
  }
  return s;
}

/// Seam-likeness summed per cell over the pixels that fall into it, and their count; the
/// intensity of the pixels on the plane (box tops) summed per cell, and their count.
struct CellSums {
  std::vector<float> sum, count;
  std::vector<float> tops, tops_count;
};

/// Whether pixel `pix` has depth within step_m of the plane: a box top, not a gap or a bevel.
bool on_top(const PixelScoring& ps, std::size_t pix) {
  const Eigen::Vector3f& p = ps.cloud.points[pix];
  return std::isfinite(p.x()) && std::isfinite(p.z()) &&
         std::abs(ps.plane.signed_distance(p.cast<double>())) <= ps.step_m;
}

/// Each pixel's seam-likeness summed into the cell it falls into, for the cells inside the mask
/// and their eight neighbours (cell_means() reads no others).
CellSums sum_cells(const PixelScoring& ps, const std::vector<int>& cell_of,
                   const std::vector<std::uint8_t>& mask_cells, int raster_width, int raster_height) {
  std::vector<std::uint8_t> read(mask_cells.size(), 0);
  cv::dilate(cv::Mat(raster_height, raster_width, CV_8U, const_cast<std::uint8_t*>(mask_cells.data())),
             cv::Mat(raster_height, raster_width, CV_8U, read.data()), cv::Mat::ones(3, 3, CV_8U));
  const std::size_t n = mask_cells.size();
  const bool tops = ps.frame.has_intensity() && ps.frame.intensity.size() == ps.frame.pixel_count();
  CellSums sums{std::vector<float>(n, 0.f), std::vector<float>(n, 0.f), {}, {}};
  if (tops) sums.tops.assign(n, 0.f), sums.tops_count.assign(n, 0.f);
  const auto width = static_cast<std::size_t>(ps.frame.intrinsics.width);
  for (std::size_t pix = 0; pix < cell_of.size(); ++pix) {
    const int cell = cell_of[pix];
    if (cell < 0 || read[static_cast<std::size_t>(cell)] == 0) continue;
    const float s = pixel_seam(ps, pix, static_cast<int>(pix % width), static_cast<int>(pix / width));
    const auto c = static_cast<std::size_t>(cell);
    sums.sum[c] += s;
    sums.count[c] += 1.f;
    if (tops && on_top(ps, pix)) {
      sums.tops[c] += static_cast<float>(ps.frame.intensity[pix]);
      sums.tops_count[c] += 1.f;
    }
  }
  return sums;
}

/// ev.seam: the mean per cell inside the mask; cells no pixel fell into take their neighbours'
/// mean (3 x 3). ev.strength: the share of the cells inside that look seam-like.
void cell_means(CellSums& sums, const std::vector<std::uint8_t>& mask_cells, SeamEvidence& ev) {
  const std::vector<float>& sum = sums.sum;
  const std::vector<float>& count = sums.count;
  cv::Mat msum(ev.height, ev.width, CV_32F, sums.sum.data());
  cv::Mat mcount(ev.height, ev.width, CV_32F, sums.count.data());
  cv::Mat nsum, ncount;
  cv::boxFilter(msum, nsum, CV_32F, cv::Size(3, 3), cv::Point(-1, -1), false);
  cv::boxFilter(mcount, ncount, CV_32F, cv::Size(3, 3), cv::Point(-1, -1), false);
  ev.seam.assign(sum.size(), 0.f);
  const auto W = static_cast<std::size_t>(ev.width);
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
      if (s > kSeamLike) ++seamy;
    }
  }
  ev.strength = inside > 0 ? static_cast<double>(seamy) / static_cast<double>(inside) : 0.0;
  if (sums.tops.empty()) return;
  ev.tops.assign(sum.size(), 0.f);
  ev.tops_seen.assign(sum.size(), 0.f);
  for (std::size_t c = 0; c < sum.size(); ++c) {
    if (mask_cells[c] == 0 || sums.tops_count[c] <= 0.f) continue;
    ev.tops[c] = sums.tops[c] / sums.tops_count[c];
    ev.tops_seen[c] = 1.f;
  }
}

}  // namespace

SeamEvidence build_seam_evidence(const Frame& frame, const OrganizedCloud& cloud,
                                 const LayerResult& layer, const SeamParams& params) {
  SeamEvidence ev;
  const Intrinsics& in = frame.intrinsics;
  if (layer.status != DetectionStatus::kOk || layer.polygons.empty() || !in.valid() ||
      cloud.width != in.width || cloud.height != in.height ||
      cloud.points.size() != frame.pixel_count()) {
    return ev;
  }
  const Plane& plane = layer.plane_camera;
  const double pitch = layout_detail::layer_pixel_pitch_m(in, layer);
  const double cell_m = params.cell_m > 0 ? params.cell_m : std::clamp(pitch, kMinCell_m, kMaxCell_m);
  const auto geo = layout_detail::layer_raster_geometry(in, layer, cell_m, kRasterMargin_m);
  if (!geo) return ev;
  ev.cell_m = geo->cell_m;
  ev.origin_m = geo->origin_m;
  ev.width = geo->width;
  ev.height = geo->height;
  const std::vector<std::uint8_t> mask_cells = inside_cells(layer, ev);

  // Pass 1: which pixels fall inside the layer, and the noise of depth and intensity there.
  const layout_detail::PixelWindow window = layout_detail::pixels_on_raster(*geo, in);
  const std::vector<int> cell_of = pixel_cells(*geo, in, window, frame.pixel_count());
  ev.depth_threshold_m = seam_depth_step_m(cloud, plane, cell_of, mask_cells, layer, params);
  const double intensity_sigma = intensity_noise(frame, cell_of, mask_cells, params);

  // Pass 2: each pixel's seam-likeness (depth below the plane, missing depth, a dark line in the
  // intensity image), averaged per cell.
  PixelScoring scoring{frame, cloud, plane, params, ev.depth_threshold_m, intensity_sigma, {}};
  if (intensity_sigma > 0)
    scoring.dark_lines = dark_line_depths(frame.intensity, in.width, in.height, window);
  CellSums sums = sum_cells(scoring, cell_of, mask_cells, ev.width, ev.height);
  cell_means(sums, mask_cells, ev);
  return ev;
}

}  // namespace palletd
