// Raster geometry in the layer frame: extent over the outline, pixel -> cell homography; binary
// cell raster morphology.
#include "layer_raster.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

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

PixelWindow pixels_on_raster(const LayerRasterGeometry& geo, const Intrinsics& in) {
  const PixelWindow whole{0, 0, in.width, in.height};
  // The raster is a rectangle on the plane. With its four corners in front of the camera, its
  // image is the convex quadrilateral of the corners' images, inside their bounding box.
  const Eigen::Matrix3d pixel_cell = geo.H_cell_pixel.inverse();
  double u_lo = 1e300, u_hi = -1e300, v_lo = 1e300, v_hi = -1e300;
  for (const auto& [x, y] : {std::pair{0, 0}, {geo.width, 0}, {0, geo.height}, {geo.width, geo.height}}) {
    const Eigen::Vector3d h = pixel_cell * Eigen::Vector3d(x, y, 1.0);
    const double u = h.x() / h.z(), v = h.y() / h.z();
    if (!std::isfinite(u) || !std::isfinite(v)) return whole;
    // The corner lies in front of the camera when the plane meets its pixel's ray ahead (cell_of).
    const double den = geo.H_cell_pixel.row(2).dot(Eigen::Vector3d(u, v, 1.0));
    if (!(-geo.plane_d * den > 0)) return whole;
    u_lo = std::min(u_lo, u), u_hi = std::max(u_hi, u), v_lo = std::min(v_lo, v), v_hi = std::max(v_hi, v);
  }
  // A pixel of margin and more against the rounding of the corners' images.
  constexpr double kMargin_px = 2.0;
  auto clamped = [](double x, int hi) {
    return static_cast<int>(std::clamp(x, 0.0, static_cast<double>(hi)));
  };
  return {clamped(std::floor(u_lo - kMargin_px), in.width), clamped(std::floor(v_lo - kMargin_px), in.height),
          clamped(std::ceil(u_hi + kMargin_px) + 1.0, in.width),
          clamped(std::ceil(v_hi + kMargin_px) + 1.0, in.height)};
}

namespace {

// A cell keeps 1 when every cell of its window is 1 (erode) or any is (dilate): `count` ones of
// the `full` cells a whole window holds (outside the raster counts as 0).
std::uint8_t window_value(int count, int full, bool erode) {
  return erode ? (count == full ? 1 : 0) : (count > 0 ? 1 : 0);
}

// One pass of a (2k+1)-wide window along each row: running sums along the row.
void row_pass(std::vector<std::uint8_t>& cells, int w, int h, int k, bool erode) {
  std::vector<int> ones(static_cast<std::size_t>(w) + 1);
  for (int y = 0; y < h; ++y) {
    std::uint8_t* row = cells.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
    for (int x = 0; x < w; ++x) {
      ones[static_cast<std::size_t>(x) + 1] = ones[static_cast<std::size_t>(x)] + row[x];
    }
    for (int x = 0; x < w; ++x) {
      const int lo = std::max(0, x - k), hi = std::min(w, x + k + 1);
      row[x] = window_value(ones[static_cast<std::size_t>(hi)] - ones[static_cast<std::size_t>(lo)],
                            2 * k + 1, erode);
    }
  }
}

// One pass of a (2k+1)-tall window down each column: a running count per column, slid down one
// row at a time (rows are read whole, in memory order).
void column_pass(std::vector<std::uint8_t>& cells, int w, int h, int k, bool erode) {
  const std::vector<std::uint8_t> in = cells;
  const auto width = static_cast<std::size_t>(w);
  auto row_of = [&](int y) { return in.data() + static_cast<std::size_t>(y) * width; };
  std::vector<int> count(width, 0);
  for (int y = 0; y <= std::min(k, h - 1); ++y) {
    const std::uint8_t* r = row_of(y);
    for (std::size_t x = 0; x < width; ++x) count[x] += r[x];
  }
  for (int y = 0; y < h; ++y) {  // count: rows y - k .. y + k of the raster
    std::uint8_t* out = cells.data() + static_cast<std::size_t>(y) * width;
    for (std::size_t x = 0; x < width; ++x) out[x] = window_value(count[x], 2 * k + 1, erode);
    if (y + k + 1 < h) {
      const std::uint8_t* r = row_of(y + k + 1);
      for (std::size_t x = 0; x < width; ++x) count[x] += r[x];
    }
    if (y - k >= 0) {
      const std::uint8_t* r = row_of(y - k);
      for (std::size_t x = 0; x < width; ++x) count[x] -= r[x];
    }
  }
}

void window_pass(std::vector<std::uint8_t>& cells, int w, int h, int k, bool along_rows, bool erode) {
  if (w <= 0 || h <= 0) return;
  if (along_rows) {
    row_pass(cells, w, h, k, erode);
  } else {
    column_pass(cells, w, h, k, erode);
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
