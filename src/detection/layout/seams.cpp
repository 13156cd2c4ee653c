// Seam evidence: gaps between boxes as depth below the plane, missing depth or intensity edges,
// resampled into a raster in the layer frame.
#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/layout.hpp"

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
  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const auto& poly : layer.polygons) {
    for (const auto& p : poly.outer) {
      bx0 = std::min(bx0, p.x()); bx1 = std::max(bx1, p.x());
      by0 = std::min(by0, p.y()); by1 = std::max(by1, p.y());
    }
  }
  if (!(bx1 > bx0 && by1 > by0)) return ev;
  const Plane& plane = layer.plane_camera;
  const double pitch = std::abs(plane.d) / std::max(in.fx, in.fy);  // [m per pixel] at the layer
  ev.cell_m = params.cell_m > 0 ? params.cell_m : std::clamp(pitch, 0.001, 0.01);
  const double margin = 0.02;
  ev.origin_m = {bx0 - margin, by0 - margin};
  ev.width = static_cast<int>(std::ceil((bx1 - bx0 + 2 * margin) / ev.cell_m));
  ev.height = static_cast<int>(std::ceil((by1 - by0 + 2 * margin) / ev.cell_m));
  if (ev.width <= 0 || ev.height <= 0 || static_cast<double>(ev.width) * ev.height > 4e6) {
    ev = SeamEvidence{};
    return ev;
  }

  // Pixel -> layer point where its ray meets the plane, as one homography H (pixel -> cell):
  // q = (R r (-d) + t (n . r)) / (n . r) with r = K^-1 (u, v, 1); the ray is used, not the
  // measured point, so that pixels without depth land where they belong.
  const Eigen::Isometry3d T_layer_camera = layer.T_camera_layer.inverse();
  Eigen::Matrix3d K_inv;
  K_inv << 1.0 / in.fx, 0.0, -in.cx / in.fx, 0.0, 1.0 / in.fy, -in.cy / in.fy, 0.0, 0.0, 1.0;
  const Eigen::Matrix3d M = -plane.d * T_layer_camera.linear() + T_layer_camera.translation() * plane.normal.transpose();
  Eigen::Matrix3d H;
  H.row(0) = (M.row(0) - ev.origin_m.x() * plane.normal.transpose()) / ev.cell_m;
  H.row(1) = (M.row(1) - ev.origin_m.y() * plane.normal.transpose()) / ev.cell_m;
  H.row(2) = plane.normal.transpose();
  H = H * K_inv;
  const auto W = static_cast<std::size_t>(ev.width);
  // Only the inside of the outline counts: the outline itself is no seam.
  cv::Mat mask = cv::Mat::zeros(ev.height, ev.width, CV_8U);
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
  cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), 2);

  // Pass 1: which pixels fall inside the layer, and the noise of depth and intensity there.
  std::vector<int> cell_of(frame.pixel_count(), -1);
  for (int v = 0; v < in.height; ++v) {
    for (int u = 0; u < in.width; ++u) {
      const double den = H(2, 0) * u + H(2, 1) * v + H(2, 2);  // n . r
      if (std::abs(den) < 1e-12 || -plane.d / den <= 0) continue;  // ray parallel or plane behind
      const double fx = (H(0, 0) * u + H(0, 1) * v + H(0, 2)) / den;
      const double fy = (H(1, 0) * u + H(1, 1) * v + H(1, 2)) / den;
      if (!(fx >= 0 && fy >= 0 && fx < ev.width && fy < ev.height)) continue;
      const int cx = static_cast<int>(fx);
      const int cy = static_cast<int>(fy);
      if (cx < 0 || cy < 0 || cx >= ev.width || cy >= ev.height) continue;
      cell_of[static_cast<std::size_t>(v) * static_cast<std::size_t>(in.width) + static_cast<std::size_t>(u)] =
          cy * ev.width + cx;
    }
  }
  std::vector<double> residuals;
  for (std::size_t pix = 0; pix < cell_of.size(); ++pix) {
    const int c = cell_of[pix];
    if (c < 0 || mask.at<std::uint8_t>(c / ev.width, c % ev.width) == 0) continue;
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

  // Intensity gradient magnitude, normalised by its robust noise level on the layer (the median
  // gradient magnitude is noise: for Gaussian noise it is 1.18 sigma of a gradient component).
  cv::Mat grad;
  double grad_sigma = 0.0;
  if (frame.has_intensity() && params.intensity_weight > 0 &&
      frame.intensity.size() == frame.pixel_count()) {
    cv::Mat inten(in.height, in.width, CV_16U, const_cast<std::uint16_t*>(frame.intensity.data()));
    cv::Mat f, gx, gy;
    inten.convertTo(f, CV_32F);
    cv::Sobel(f, gx, CV_32F, 1, 0, 3);
    cv::Sobel(f, gy, CV_32F, 0, 1, 3);
    cv::magnitude(gx, gy, grad);
    std::vector<double> sample;
    for (std::size_t pix = 0; pix < cell_of.size(); ++pix) {
      const int c = cell_of[pix];
      if (c < 0 || mask.at<std::uint8_t>(c / ev.width, c % ev.width) == 0) continue;
      sample.push_back(grad.at<float>(static_cast<int>(pix)));
    }
    if (sample.size() >= 20) {
      const auto k = sample.size() / 2;
      std::nth_element(sample.begin(), sample.begin() + static_cast<long>(k), sample.end());
      // A floor of one count keeps noise-free (synthetic) intensity from dividing by zero.
      grad_sigma = std::max(sample[k] / 1.18, 1.0);
    }
  }

  std::vector<float> sum(W * static_cast<std::size_t>(ev.height), 0.f), count(sum.size(), 0.f);
  const double g_lo = params.intensity_noise_k;
  for (std::size_t pix = 0; pix < cell_of.size(); ++pix) {
    const int cell = cell_of[pix];
    if (cell < 0) continue;
    const Eigen::Vector3f& p = cloud.points[pix];
    float s;
    if (!std::isfinite(p.x()) || !std::isfinite(p.z())) {
      // No measurement: a gap or a dark edge, or a random dropout. The layout stage keeps only
      // line-like runs of these along its axes (SeamTable), so scattered dropouts fade.
      s = 1.f;
    } else {
      const double below = -plane.signed_distance(p.cast<double>());
      s = static_cast<float>(std::clamp((below - step) / step, 0.0, 1.0));
    }
    if (grad_sigma > 0) {
      const double z = grad.at<float>(static_cast<int>(pix)) / grad_sigma;
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
      if (mask.at<std::uint8_t>(y, x) == 0) continue;
      const std::size_t c = static_cast<std::size_t>(y) * W + static_cast<std::size_t>(x);
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
