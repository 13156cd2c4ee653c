// Cell rasters of the layout stage: summed-area tables computed into the caller's vector
// (integral_into) and read bilinearly (sat_sum_bilinear), as the seam table, the tape evidence
// and the area oracle read them; square erosion, dilation and opening of binary rasters; the image
// rectangle the per-pixel passes over a layer's raster visit; the best-first search's free runs
// over its occupancy bits.
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <opencv2/core.hpp>

#include "evidence/seam_raster.hpp"
#include "layer_raster.hpp"
#include "search/best_first_internal.hpp"

using namespace palletd::layout_detail;

namespace {

/// A w x h image of distinct values, so that a sum over the wrong cells shows.
cv::Mat ramp(int w, int h, int type) {
  cv::Mat image(h, w, type);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int value = (x * 7 + y * 13) % 11;
      if (type == CV_8U)
        image.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(value);
      else
        image.at<float>(y, x) = 0.25F * static_cast<float>(value);
    }
  }
  return image;
}

double loop_sum(const cv::Mat& image, int x0, int y0, int x1, int y1) {
  double sum = 0.0;
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      sum += image.type() == CV_8U ? image.at<std::uint8_t>(y, x) : image.at<float>(y, x);
    }
  }
  return sum;
}

/// Square window of half-width k by definition: every (erode) or any (dilate) cell within k along
/// both axes is 1, cells beyond the raster 0.
std::vector<std::uint8_t> brute_window(const std::vector<std::uint8_t>& cells, int w, int h, int k,
                                       bool erode) {
  std::vector<std::uint8_t> out(cells.size());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      bool all = true, any = false;
      for (int dy = -k; dy <= k; ++dy) {
        for (int dx = -k; dx <= k; ++dx) {
          const int u = x + dx, v = y + dy;
          const bool on =
              u >= 0 && v >= 0 && u < w && v < h && cells[static_cast<std::size_t>(v * w + u)] != 0;
          all = all && on;
          any = any || on;
        }
      }
      out[static_cast<std::size_t>(y * w + x)] = (erode ? all : any) ? 1 : 0;
    }
  }
  return out;
}

}  // namespace

TEST_CASE("square erosion, dilation and opening of a cell raster match their definition",
          "[layout][raster]") {
  std::mt19937 rng(20261204);
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{7, 3}, std::pair{23, 31}, std::pair{64, 9}}) {
    for (const int k : {0, 1, 2, 4}) {
      for (const double density : {0.5, 0.9}) {
        std::bernoulli_distribution on(density);
        std::vector<std::uint8_t> cells(static_cast<std::size_t>(w * h));
        for (auto& c : cells) c = on(rng) ? 1 : 0;
        INFO(w << "x" << h << " k " << k << " density " << density);
        std::vector<std::uint8_t> eroded = cells, dilated = cells, opened = cells;
        erode_square(eroded, w, h, k);
        dilate_square(dilated, w, h, k);
        open_square(opened, w, h, k);
        CHECK(eroded == brute_window(cells, w, h, k, true));
        CHECK(dilated == brute_window(cells, w, h, k, false));
        CHECK(opened == brute_window(brute_window(cells, w, h, k, true), w, h, k, false));
      }
    }
  }
}

TEST_CASE("a summed-area table written into a reused vector sums every whole-cell rectangle as a loop does",
          "[layout][seams]") {
  const int w = 9, h = 6;
  for (const int type : {CV_8U, CV_32F}) {
    const cv::Mat image = ramp(w, h, type);
    // The vector held a larger table and other values before: they must not leak through.
    std::vector<double> sat(500, -3.0);
    integral_into(image, sat);
    REQUIRE(sat.size() == static_cast<std::size_t>((w + 1) * (h + 1)));
    for (int y0 = 0; y0 < h; ++y0) {
      for (int x0 = 0; x0 < w; ++x0) {
        for (const auto& [x1, y1] : {std::pair{x0 + 1, y0 + 1}, std::pair{w, h}, std::pair{x0 + 2, h}}) {
          if (x1 > w || y1 > h) continue;
          CHECK(sat_sum_bilinear(sat, w, h, x0, y0, x1, y1) == Approx(loop_sum(image, x0, y0, x1, y1)));
        }
      }
    }
    // A smaller table after it: the vector shrinks to the new size.
    integral_into(image(cv::Rect(0, 0, 3, 2)).clone(), sat);
    CHECK(sat.size() == 12U);
    CHECK(sat.back() == Approx(loop_sum(image, 0, 0, 3, 2)));
  }
}

TEST_CASE("a bilinear read of a summed-area table takes the covered share of each cell", "[layout][seams]") {
  cv::Mat image(2, 2, CV_32F, cv::Scalar(0));
  image.at<float>(0, 0) = 4.0F;
  image.at<float>(1, 1) = 8.0F;
  std::vector<double> sat;
  integral_into(image, sat);
  // Half of the first cell across, the whole of it down: 2; a quarter of each cell: 3.
  CHECK(sat_sum_bilinear(sat, 2, 2, 0.5, 0.0, 1.0, 1.0) == Approx(2.0));
  CHECK(sat_sum_bilinear(sat, 2, 2, 0.5, 0.5, 1.5, 1.5) == Approx(0.25 * 4.0 + 0.25 * 8.0));
}

namespace {

/// A layer on a plane turned tilt_deg about the camera's x axis, d_m from the camera, whose
/// outline is a rectangle of half sides half_x_m, half_y_m around where the optical axis meets
/// the plane; the layer frame as stage 2 builds it (z the plane's normal toward the camera).
palletd::LayerResult tilted_layer(double tilt_deg, double d_m, double half_x_m, double half_y_m) {
  palletd::LayerResult layer;
  layer.status = palletd::DetectionStatus::kOk;
  const double t = tilt_deg * M_PI / 180.0;
  const Eigen::Vector3d n(0.0, std::sin(t), -std::cos(t));
  layer.plane_camera.normal = n;
  layer.plane_camera.d = d_m;
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - n * n.x();
  x.normalize();
  layer.T_camera_layer.linear().col(0) = x;
  layer.T_camera_layer.linear().col(1) = n.cross(x);
  layer.T_camera_layer.linear().col(2) = n;
  layer.T_camera_layer.translation() = -d_m * n;  // the camera's foot point
  const Eigen::Vector3d on_axis(0.0, 0.0, -d_m / n.z());
  const Eigen::Vector2d c = (layer.T_camera_layer.inverse() * on_axis).head<2>();
  palletd::PolygonWithHoles rect;
  rect.outer = {c + Eigen::Vector2d(-half_x_m, -half_y_m), c + Eigen::Vector2d(half_x_m, -half_y_m),
                c + Eigen::Vector2d(half_x_m, half_y_m), c + Eigen::Vector2d(-half_x_m, half_y_m)};
  layer.polygons.push_back(rect);
  return layer;
}

palletd::Intrinsics vga() {
  palletd::Intrinsics in;
  in.width = 640;
  in.height = 480;
  in.fx = 520.0;
  in.fy = 500.0;
  in.cx = 319.5;
  in.cy = 239.5;
  return in;
}

/// Pixels whose ray meets the raster, and those of them outside `w`.
std::pair<int, int> pixels_on(const LayerRasterGeometry& geo, const palletd::Intrinsics& in,
                              const PixelWindow& w) {
  int on = 0, outside = 0;
  for (int v = 0; v < in.height; ++v) {
    for (int u = 0; u < in.width; ++u) {
      double fx = 0.0, fy = 0.0;
      if (!geo.cell_of(u, v, &fx, &fy)) continue;
      ++on;
      if (u < w.u0 || u >= w.u1 || v < w.v0 || v >= w.v1) ++outside;
    }
  }
  return {on, outside};
}

}  // namespace

TEST_CASE("the pixels a raster's per-pixel passes visit hold every pixel whose ray meets it",
          "[layout][seams]") {
  const palletd::Intrinsics in = vga();
  for (const double tilt_deg : {0.0, 12.0, 30.0}) {
    const palletd::LayerResult layer = tilted_layer(tilt_deg, 2.0, 0.4, 0.3);
    const auto geo = layer_raster_geometry(in, layer, 0.004, 0.02);
    REQUIRE(geo);
    const PixelWindow w = pixels_on_raster(*geo, in);
    const auto [on, outside] = pixels_on(*geo, in, w);
    CHECK(on > 10000);
    CHECK(outside == 0);
    // Tight: the window is the raster's image, a few pixels of margin around it, not the image.
    CHECK((w.u1 - w.u0) * (w.v1 - w.v0) < 2 * on);
    CHECK((w.u1 - w.u0) * (w.v1 - w.v0) < in.width * in.height / 2);
  }
  // A raster reaching behind the camera (a plane nearly along the view, an outline 20 m long):
  // its corners' images say nothing, so the whole image is visited.
  const palletd::LayerResult far = tilted_layer(70.0, 1.0, 0.4, 10.0);
  const auto geo = layer_raster_geometry(in, far, 0.05, 0.02);
  REQUIRE(geo);
  const PixelWindow w = pixels_on_raster(*geo, in);
  CHECK(pixels_on(*geo, in, w).second == 0);
  CHECK((w.u0 == 0 && w.v0 == 0 && w.u1 == in.width && w.v1 == in.height));
}

TEST_CASE("the search's free runs tell a placement's fit as its cells one by one do", "[layout][search]") {
  using palletd::layout_detail::best_first::FreeRuns;
  using palletd::layout_detail::best_first::Placement;
  std::mt19937 rng(20261206);
  for (const auto& grid : {std::pair{7, 5}, std::pair{64, 3}, std::pair{70, 9}, std::pair{13, 40}}) {
    const int nx = grid.first, ny = grid.second;  // plain locals: lambdas below capture them
    const int cells = nx * ny;
    for (int trial = 0; trial < 40; ++trial) {
      // Occupancies from sparse to dense; unused bits of the last word left set as well.
      std::vector<std::uint64_t> occ((static_cast<std::size_t>(cells) + 63) / 64 + 1, 0);
      const double share = 0.05 + 0.9 * trial / 40.0;
      for (auto& word : occ)
        for (int b = 0; b < 64; ++b)
          if (std::uniform_real_distribution<double>(0, 1)(rng) < share) word |= std::uint64_t{1} << b;
      auto occupied = [&](int i, int j) {
        return ((occ[static_cast<std::size_t>((j * nx + i) >> 6)] >> ((j * nx + i) & 63)) & 1U) != 0;
      };
      for (int cell = 0; cell < cells; ++cell) {
        const int i = cell % nx, j = cell / nx;
        int run = 0;
        while (i + run < nx && !occupied(i + run, j)) ++run;
        CHECK(palletd::layout_detail::best_first::free_bits_from(occ.data(), cell, nx - i) == run);
        FreeRuns runs(occ.data(), cell, nx);
        // Placements at the cell, short and tall by turns: rows read before are read again.
        for (int i1 = i + 1; i1 <= nx; ++i1) {
          for (int j1 = j + 1; j1 <= ny; j1 += 1 + (j1 % 3)) {
            bool free = true;
            for (int y = j; y < j1 && free; ++y)
              for (int x = i; x < i1 && free; ++x) free = !occupied(x, y);
            const Placement p{0, i1, j1, 0.0, 0.0};
            CHECK(runs.fits(p) == free);
          }
        }
      }
    }
  }
}

TEST_CASE("the occupancy's ranges and next free cells agree with its bits one by one", "[layout][search]") {
  // Ranges that start and end anywhere in a word, fill one word exactly or span several; the next
  // free cell from every cell, with a limit inside the last word.
  std::mt19937 rng(61206);
  constexpr int kCells = 300;
  for (int trial = 0; trial < 400; ++trial) {
    std::vector<std::uint64_t> occ((kCells + 63) / 64, 0);
    std::vector<bool> bits(kCells, false);
    for (int r = 0; r < 1 + trial % 7; ++r) {
      const int start = std::uniform_int_distribution<int>(0, kCells - 1)(rng);
      const int max_len = std::min(kCells - start, trial % 3 == 0 ? 64 : 200);
      const int len = std::uniform_int_distribution<int>(1, max_len)(rng);
      best_first::set_range(occ.data(), start, len);
      for (int b = start; b < start + len; ++b) bits[static_cast<std::size_t>(b)] = true;
    }
    for (int b = 0; b < kCells; ++b)
      CHECK(((occ[static_cast<std::size_t>(b >> 6)] >> (b & 63)) & 1U) ==
            (bits[static_cast<std::size_t>(b)] ? 1U : 0U));
    const int limit = kCells - trial % 5;
    for (int from = 0; from < limit; ++from) {
      int next = from;
      while (next < limit && bits[static_cast<std::size_t>(next)]) ++next;
      CHECK(best_first::next_free_bit(occ.data(), from, limit) == next);
    }
  }
}

TEST_CASE("the frontier table keeps each key's entry within a search and none across searches",
          "[layout][search]") {
  // Random keys against std::map over several searches; keys drawn from a small set collide in
  // the table's index often, and the table grows from empty past several doublings.
  best_first::FrontierTable table;
  std::mt19937_64 rng(17);
  for (int search = 0; search < 4; ++search) {
    table.clear();
    std::map<std::uint64_t, std::size_t> truth;
    const std::uint64_t spread = search % 2 == 0 ? 5000 : std::uint64_t{1} << 40;
    for (int op = 0; op < 20000; ++op) {
      const std::uint64_t key = (rng() % spread) << (search == 3 ? 44 : 0);  // search 3: low bits all zero
      best_first::Dominance& d = table[key];
      REQUIRE(d.count == truth[key]);
      ++d.count;
      d.best = static_cast<double>(key);
      ++truth[key];
    }
    CHECK(table.size() == truth.size());
    for (const auto& entry : truth) {
      const best_first::Dominance& d = table[entry.first];
      CHECK(d.count == entry.second);
      CHECK(d.best == static_cast<double>(entry.first));
    }
    CHECK(table.capacity() >= 2 * truth.size());
  }
  table.hold(100);
  CHECK(table.capacity() == 1024);
  CHECK(table.size() == 0);
  CHECK(table[42].count == 0);
}
