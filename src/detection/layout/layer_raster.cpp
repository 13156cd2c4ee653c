// Raster geometry in the layer frame: extent over the outline, pixel -> cell homography.
#include "layer_raster.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace palletd::layout_detail {

double layer_pixel_pitch_m(const Intrinsics& in, const LayerResult& layer) {
  return std::abs(layer.plane_camera.d) / std::max(in.fx, in.fy);
}

std::optional<LayerRasterGeometry> layer_raster_geometry(const Intrinsics& in, const LayerResult& layer,
                                                         double cell_m, double margin_m) {
  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const auto& poly : layer.polygons) {
    for (const auto& p : poly.outer) {
      bx0 = std::min(bx0, p.x());
      bx1 = std::max(bx1, p.x());
      by0 = std::min(by0, p.y());
      by1 = std::max(by1, p.y());
    }
  }
  if (!(bx1 > bx0 && by1 > by0) || !(cell_m > 0.0)) return std::nullopt;
  LayerRasterGeometry g;
  g.cell_m = cell_m;
  g.origin_m = {bx0 - margin_m, by0 - margin_m};
  g.width = static_cast<int>(std::ceil((bx1 - bx0 + 2 * margin_m) / cell_m));
  g.height = static_cast<int>(std::ceil((by1 - by0 + 2 * margin_m) / cell_m));
  if (g.width <= 0 || g.height <= 0 || static_cast<double>(g.width) * g.height > 4e6) return std::nullopt;

  // Pixel -> layer point where its ray meets the plane, as one homography (pixel -> cell):
  // q = (R r (-d) + t (n . r)) / (n . r) with r = K^-1 (u, v, 1); the ray is used, not the
  // measured point, so that pixels without depth land where they belong.
  const Plane& plane = layer.plane_camera;
  g.plane_d = plane.d;
  const Eigen::Isometry3d T_layer_camera = layer.T_camera_layer.inverse();
  Eigen::Matrix3d K_inv;
  K_inv << 1.0 / in.fx, 0.0, -in.cx / in.fx, 0.0, 1.0 / in.fy, -in.cy / in.fy, 0.0, 0.0, 1.0;
  const Eigen::Matrix3d M =
      -plane.d * T_layer_camera.linear() + T_layer_camera.translation() * plane.normal.transpose();
  Eigen::Matrix3d H;
  H.row(0) = (M.row(0) - g.origin_m.x() * plane.normal.transpose()) / cell_m;
  H.row(1) = (M.row(1) - g.origin_m.y() * plane.normal.transpose()) / cell_m;
  H.row(2) = plane.normal.transpose();
  g.H_cell_pixel = H * K_inv;
  return g;
}

}  // namespace palletd::layout_detail
