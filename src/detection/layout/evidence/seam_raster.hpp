// Private to the layout stage: the seam raster read in a layout frame, shared by SeamTable
// (layout_internal.hpp) and SeamLikelihood (seam_likelihood.hpp).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "layout_internal.hpp"

namespace palletd::layout_detail {

/// The seam raster turned into a layout frame: cell (col, row) of the width x height result
/// (cells of seams.cell_m) holds the seam value at frame point (x0_m + (col + 0.5) cell,
/// y0_m + (row + 0.5) cell), bilinear; 0 off the raster.
cv::Mat seams_in_frame(const SeamEvidence& seams, const LayoutFrame& frame, double x0_m, double y0_m, int width,
                       int height);

/// Any raster of the seam raster's geometry (`values`: seams.width x seams.height, row-major)
/// turned into a layout frame like seams_in_frame().
cv::Mat raster_in_frame(const std::vector<float>& values, const SeamEvidence& seams, const LayoutFrame& frame,
                        double x0_m, double y0_m, int width, int height);

/// The summed-area table of a one-channel image, (rows + 1) x (cols + 1) doubles row-major,
/// computed straight into `sat` (its buffer reused; no copy of a table that can be megabytes).
void integral_into(const cv::Mat& image, std::vector<double>& sat);

/// Sum of a (w + 1) x (h + 1) summed-area table over the fractional cell rectangle
/// [fx0, fx1) x [fy0, fy1) (inside 0..w, 0..h), read bilinearly: exact for values constant per cell.
double sat_sum_bilinear(const std::vector<double>& sat, int w, int h, double fx0, double fy0, double fx1, double fy1);

}  // namespace palletd::layout_detail
