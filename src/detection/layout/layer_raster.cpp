// Raster geometry in the layer frame: extent over the outline, pixel -> cell homography; binary
// cell raster morphology.
#include "layer_raster.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "layout_internal.hpp"

namespace palletd::layout_detail {

double layer_pixel_pitch_m(const Intrinsics& in, const LayerResult& layer) {
  return std::abs(layer.plane_camera.d) / std::max(in.fx, in.fy);
}

std::optional<LayerRasterGeometry> layer_raster_geometry(const Intrinsics& in, const LayerResult& layer,
                                                         double cell_m, double margin_m) {
  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const auto& poly : layer.polygons) {
    const Rect b = bounds_of(poly);
    bx0 = std::min(bx0, b.x0);
    bx1 = std::max(bx1, b.x1);
    by0 = std::min(by0, b.y0);
    by1 = std::max(by1, b.y1);
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

namespace {

// One pass of a (2k+1)-wide window along rows (along_rows) or columns: a cell keeps 1 when every
// cell of its window is 1 (erode) or any is (dilate); outside the raster counts as 0.
void window_pass(std::vector<std::uint8_t>& cells, int w, int h, int k, bool along_rows, bool erode) {
  const int n = along_rows ? w : h, lines = along_rows ? h : w;
  std::vector<int> ones(static_cast<std::size_t>(n) + 1);
  std::vector<std::uint8_t> out(static_cast<std::size_t>(n));
  auto at = [&](int line, int i) -> std::uint8_t& {
    const int x = along_rows ? i : line, y = along_rows ? line : i;
    return cells[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)];
  };
  for (int line = 0; line < lines; ++line) {
    for (int i = 0; i < n; ++i) ones[static_cast<std::size_t>(i) + 1] = ones[static_cast<std::size_t>(i)] + at(line, i);
    for (int i = 0; i < n; ++i) {
      const int lo = std::max(0, i - k), hi = std::min(n, i + k + 1);
      const int count = ones[static_cast<std::size_t>(hi)] - ones[static_cast<std::size_t>(lo)];
      out[static_cast<std::size_t>(i)] = erode ? (count == 2 * k + 1 ? 1 : 0) : (count > 0 ? 1 : 0);
    }
    for (int i = 0; i < n; ++i) at(line, i) = out[static_cast<std::size_t>(i)];
  }
}

}  // namespace

void erode_square(std::vector<std::uint8_t>& cells, int w, int h, int k) {
  window_pass(cells, w, h, k, true, true);
  window_pass(cells, w, h, k, false, true);
}

void dilate_square(std::vector<std::uint8_t>& cells, int w, int h, int k) {
  window_pass(cells, w, h, k, true, false);
  window_pass(cells, w, h, k, false, false);
}

void open_square(std::vector<std::uint8_t>& cells, int w, int h, int k) {
  window_pass(cells, w, h, k, true, true);
  window_pass(cells, w, h, k, false, true);
  window_pass(cells, w, h, k, true, false);
  window_pass(cells, w, h, k, false, false);
}

std::size_t largest_piece_cells(std::vector<std::uint8_t>& cells, int w, int h) {
  std::size_t largest = 0;
  std::vector<int> stack;
  for (int start = 0; start < w * h; ++start) {
    if (cells[static_cast<std::size_t>(start)] != 1) continue;
    std::size_t area = 0;
    cells[static_cast<std::size_t>(start)] = 2;
    stack.push_back(start);
    while (!stack.empty()) {
      const int c = stack.back();
      stack.pop_back();
      ++area;
      const int cx = c % w, cy = c / w;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int x = cx + dx, y = cy + dy;
          if (x < 0 || y < 0 || x >= w || y >= h) continue;
          auto& v = cells[static_cast<std::size_t>(y * w + x)];
          if (v == 1) {
            v = 2;
            stack.push_back(y * w + x);
          }
        }
      }
    }
    largest = std::max(largest, area);
  }
  return largest;
}

}  // namespace palletd::layout_detail
