// SeamTable (layout_internal.hpp) and the seam raster turned into a layout frame (seam_raster.hpp).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "evidence/seam_raster.hpp"
#include "layout_internal.hpp"

namespace palletd::layout_detail {

cv::Mat seams_in_frame(const SeamEvidence& seams, const LayoutFrame& frame, double x0_m, double y0_m, int width,
                       int height) {
  return raster_in_frame(seams.seam, seams, frame, x0_m, y0_m, width, height);
}

cv::Mat raster_in_frame(const std::vector<float>& values, const SeamEvidence& seams, const LayoutFrame& frame,
                        double x0_m, double y0_m, int width, int height) {
  const double cell = seams.cell_m;
  // dst pixel (c, r) -> frame q -> layer p -> src pixel; an affine map.
  const double c = std::cos(frame.theta_rad), s = std::sin(frame.theta_rad);
  const double k = 1.0 / seams.cell_m;
  // q = (x0 + (col + 0.5) cell, y0 + (row + 0.5) cell); p = R q + pivot; src = (p - origin) k - 0.5
  const double qx0 = x0_m + 0.5 * cell, qy0 = y0_m + 0.5 * cell;
  cv::Matx23d m(k * c * cell, -k * s * cell,
                k * (c * qx0 - s * qy0 + frame.pivot.x() - seams.origin_m.x()) - 0.5,
                k * s * cell, k * c * cell,
                k * (s * qx0 + c * qy0 + frame.pivot.y() - seams.origin_m.y()) - 0.5);
  const cv::Mat src(seams.height, seams.width, CV_32F, const_cast<float*>(values.data()));
  cv::Mat dst;
  cv::warpAffine(src, dst, m, cv::Size(width, height), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_CONSTANT, cv::Scalar(0));
  return dst;
}

void integral_into(const cv::Mat& image, std::vector<double>& sat) {
  const int rows = image.rows + 1, cols = image.cols + 1;
  sat.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
  cv::Mat table(rows, cols, CV_64F, sat.data());
  cv::integral(image, table, CV_64F);  // fits the given buffer: written in place
  if (table.data != reinterpret_cast<std::uint8_t*>(sat.data())) {
    sat.assign(table.ptr<double>(), table.ptr<double>() + table.total());
  }
}

double sat_sum_bilinear(const std::vector<double>& sat, int w, int h, double fx0, double fy0, double fx1, double fy1) {
  // Bilinear lookup in the integral image: exact for values constant per cell, so strips at any
  // offset (seam profiles) read without the bias of rounding to whole cells.
  const auto W = static_cast<std::size_t>(w + 1);
  auto sample = [&](double fx, double fy) {
    const int ix = std::min(static_cast<int>(fx), w - 1), iy = std::min(static_cast<int>(fy), h - 1);
    const double tx = fx - ix, ty = fy - iy;
    auto at = [&](int row, int col) { return sat[static_cast<std::size_t>(row) * W + static_cast<std::size_t>(col)]; };
    return (1 - ty) * ((1 - tx) * at(iy, ix) + tx * at(iy, ix + 1)) +
           ty * ((1 - tx) * at(iy + 1, ix) + tx * at(iy + 1, ix + 1));
  };
  return sample(fx1, fy1) - sample(fx0, fy1) - sample(fx1, fy0) + sample(fx0, fy0);
}

SeamTable::SeamTable(const SeamEvidence& seams, const LayoutFrame& frame, const Rect& bounds) {
  if (seams.empty()) return;
  cell_ = seams.cell_m;
  x0_ = bounds.x0 - 2 * cell_;
  y0_ = bounds.y0 - 2 * cell_;
  w_ = static_cast<int>(std::ceil((bounds.x1 - bounds.x0) / cell_)) + 4;
  h_ = static_cast<int>(std::ceil((bounds.y1 - bounds.y0) / cell_)) + 4;
  if (w_ <= 0 || h_ <= 0 || static_cast<double>(w_) * h_ > 4e6) {
    w_ = h_ = 0;
    return;
  }
  const cv::Mat dst = seams_in_frame(seams, frame, x0_, y0_, w_, h_);
  // Seams between boxes are axis-aligned lines here: average along each axis so that lines keep
  // their value and scattered dropouts fade, then keep the line-like part.
  const int k_len = std::max(3, static_cast<int>(std::lround(0.04 / cell_)) | 1);
  cv::Mat along_x, along_y;
  cv::blur(dst, along_x, cv::Size(k_len, 1));
  cv::blur(dst, along_y, cv::Size(1, k_len));
  cv::Mat line = cv::max(along_x, along_y);
  line = (line - 0.3) * (1.0 / 0.4);
  cv::threshold(line, line, 1.0, 1.0, cv::THRESH_TRUNC);
  cv::threshold(line, line, 0.0, 0.0, cv::THRESH_TOZERO);
  integral_into(line, sat_);
  // Edge support: a seam line within a few millimetres of a box edge supports it (gaps have
  // width); from the line-filtered raster, so that scattered dropouts and noise next to an edge
  // do not count as a seam along it.
  const int d = std::max(3, static_cast<int>(std::lround(0.008 / cell_)) * 2 + 1);
  cv::Mat wide;
  cv::dilate(line, wide, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(d, d)));
  integral_into(wide, sat_support_);
}

double SeamTable::sum_cells(const std::vector<double>& sat, const Rect& r, double* cells) const {
  const double fx0 = std::clamp((r.x0 - x0_) / cell_, 0.0, static_cast<double>(w_));
  const double fx1 = std::clamp((r.x1 - x0_) / cell_, 0.0, static_cast<double>(w_));
  const double fy0 = std::clamp((r.y0 - y0_) / cell_, 0.0, static_cast<double>(h_));
  const double fy1 = std::clamp((r.y1 - y0_) / cell_, 0.0, static_cast<double>(h_));
  if (fx1 <= fx0 || fy1 <= fy0) {
    *cells = 0;
    return 0.0;
  }
  *cells = (fx1 - fx0) * (fy1 - fy0);
  return sat_sum_bilinear(sat, w_, h_, fx0, fy0, fx1, fy1);
}

double SeamTable::mass(const Rect& r) const {
  if (empty()) return 0.0;
  double cells = 0;
  return sum_cells(sat_, r, &cells) * cell_ * cell_;
}

double SeamTable::mean(const Rect& r) const {
  if (empty()) return 0.0;
  double cells = 0;
  const double s = sum_cells(sat_, r, &cells);
  return cells > 0 ? s / cells : 0.0;
}

double SeamTable::support(const Rect& r) const {
  if (empty()) return 0.0;
  double cells = 0;
  const double s = sum_cells(sat_support_, r, &cells);
  return cells > 0 ? s / cells : 0.0;
}

}  // namespace palletd::layout_detail
