// Private to the layout stage: the geometry shared by the rasters built from a frame in the layer
// frame (seam evidence, surroundings): their extent over the layer's outline and the map from a
// pixel to the cell where its viewing ray meets the layer plane.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "palletd/core/frame.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd::layout_detail {

struct LayerRasterGeometry {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();  ///< layer-frame corner of cell (0, 0) [m]
  double cell_m = 0.0;                                 ///< cell side [m]
  int width = 0, height = 0;                           ///< cells
  Eigen::Matrix3d H_cell_pixel = Eigen::Matrix3d::Zero();  ///< (u, v, 1) -> cell, homogeneous
  double plane_d = 0.0;                                ///< the layer plane's offset (camera frame)

  /// Cell coordinates (fractional) where the ray of pixel (u, v) meets the plane; false when the
  /// ray is parallel to the plane, the plane lies behind the camera, or the point is off the raster.
  bool cell_of(int u, int v, double* fx, double* fy) const {
    const double den = H_cell_pixel(2, 0) * u + H_cell_pixel(2, 1) * v + H_cell_pixel(2, 2);  // n . r
    if (std::abs(den) < 1e-12 || -plane_d * den <= 0) return false;  // the plane behind the camera
    const double inv_den = 1.0 / den;
    *fx = (H_cell_pixel(0, 0) * u + H_cell_pixel(0, 1) * v + H_cell_pixel(0, 2)) * inv_den;
    *fy = (H_cell_pixel(1, 0) * u + H_cell_pixel(1, 1) * v + H_cell_pixel(1, 2)) * inv_den;
    return *fx >= 0 && *fy >= 0 && *fx < width && *fy < height;
  }
};

/// An image rectangle: columns [u0, u1), rows [v0, v1).
struct PixelWindow {
  int u0 = 0, v0 = 0, u1 = 0, v1 = 0;
};

/// The pixels whose ray can meet the raster (LayerRasterGeometry::cell_of true) all lie in this
/// rectangle of the image (the whole image when a raster corner lies behind the camera). The
/// per-pixel passes over a layer's raster visit only these.
PixelWindow pixels_on_raster(const LayerRasterGeometry& geo, const Intrinsics& in);

/// The raster over the bounding box of the layer's outer rings grown by margin_m on each side,
/// with cells of cell_m; nullopt when the layer has no extent or the raster would exceed 4e6 cells.
/// `layer` must be ok with polygons, `in` valid.
std::optional<LayerRasterGeometry> layer_raster_geometry(const Intrinsics& in, const LayerResult& layer,
                                                         double cell_m, double margin_m);

/// The layer's pixel pitch at its plane [m per pixel].
double layer_pixel_pitch_m(const Intrinsics& in, const LayerResult& layer);

// Binary cell rasters (one byte per cell, 0 or 1, row-major, w x h), worked on the caller's
// thread: OpenCV's morphology and labelling spread over its worker threads, and the detection
// library runs none of its own.

/// Erosion with a (2k+1)^2 square: a cell stays 1 when every cell within k of it is 1; cells
/// beyond the raster count as 0.
void erode_square(std::vector<std::uint8_t>& cells, int w, int h, int k);

/// Dilation with a (2k+1)^2 square: a cell becomes 1 when any cell within k of it is 1.
void dilate_square(std::vector<std::uint8_t>& cells, int w, int h, int k);

/// Morphological opening with a (2k+1)^2 square: pieces narrower than 2k+1 cells vanish.
void open_square(std::vector<std::uint8_t>& cells, int w, int h, int k);

/// Cells of the largest 8-connected piece of 1s (the pieces are marked 2 on the way).
std::size_t largest_piece_cells(std::vector<std::uint8_t>& cells, int w, int h);

}  // namespace palletd::layout_detail
