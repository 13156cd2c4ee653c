// palletd sim: industrial layer patterns (nominal footprints) and depalletizing orders.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "sim_internal.hpp"

namespace palletd::sim::detail {
namespace {

constexpr double kEps = 1e-9;

/// Cell size of a format in an orientation: 0 = long side along x, 1 = along y.
Eigen::Vector2d cell(const BoxFormatSpec& f, int orientation) {
  return orientation == 0 ? Eigen::Vector2d(f.long_m, f.short_m) : Eigen::Vector2d(f.short_m, f.long_m);
}

int fit_count(double extent, double size) {
  return size <= 0.0 ? 0 : static_cast<int>(std::floor((extent + kEps) / size));
}

/// Grid of one format and orientation, centred in the rectangle [x0, x0+w] x [y0, y0+h].
void fill_block(std::vector<PlacedBox>& out, int format, const BoxFormatSpec& f, int orientation,
                double x0, double y0, double w, double h) {
  const Eigen::Vector2d c = cell(f, orientation);
  const int nx = fit_count(w, c.x());
  const int ny = fit_count(h, c.y());
  const double sx = x0 + 0.5 * (w - nx * c.x());
  const double sy = y0 + 0.5 * (h - ny * c.y());
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      out.push_back({Eigen::Vector2d(sx + (i + 0.5) * c.x(), sy + (j + 0.5) * c.y()),
                     orientation == 0 ? 0.0 : kPi / 2.0, format});
}

int block_count(const BoxFormatSpec& f, int orientation, double w, double h) {
  const Eigen::Vector2d c = cell(f, orientation);
  return fit_count(w, c.x()) * fit_count(h, c.y());
}

int best_orientation(const BoxFormatSpec& f, double w, double h) {
  return block_count(f, 1, w, h) > block_count(f, 0, w, h) ? 1 : 0;
}

std::vector<PlacedBox> block(const std::vector<BoxFormatSpec>& formats, double a, double b) {
  std::vector<PlacedBox> out;
  fill_block(out, 0, formats[0], best_orientation(formats[0], a, b), 0.0, 0.0, a, b);
  return out;
}

/// Two blocks of opposite orientation side by side (split along x or along y), the best count.
std::vector<PlacedBox> interlock(const std::vector<BoxFormatSpec>& formats, double a, double b) {
  const BoxFormatSpec& f = formats[0];
  int best = 0;
  std::vector<PlacedBox> best_boxes;
  for (int along_y = 0; along_y < 2; ++along_y) {
    const double len = along_y ? b : a;
    const double wid = along_y ? a : b;
    for (int o = 0; o < 2; ++o) {
      const double step = along_y ? cell(f, o).y() : cell(f, o).x();
      for (int k = 1; k * step <= len + kEps; ++k) {
        const double first = k * step;
        const int n1 = along_y ? block_count(f, o, wid, first) : block_count(f, o, first, wid);
        const int n2 = along_y ? block_count(f, 1 - o, wid, len - first)
                               : block_count(f, 1 - o, len - first, wid);
        if (n1 == 0 || n2 == 0 || n1 + n2 <= best) continue;
        best = n1 + n2;
        best_boxes.clear();
        if (along_y) {
          fill_block(best_boxes, 0, f, o, 0.0, 0.0, wid, first);
          fill_block(best_boxes, 0, f, 1 - o, 0.0, first, wid, len - first);
        } else {
          fill_block(best_boxes, 0, f, o, 0.0, 0.0, first, wid);
          fill_block(best_boxes, 0, f, 1 - o, first, 0.0, len - first, wid);
        }
      }
    }
  }
  return best > 0 ? best_boxes : block(formats, a, b);
}

/// Rows whose seams are offset by half a box from row to row.
std::vector<PlacedBox> brick(const std::vector<BoxFormatSpec>& formats, double a, double b) {
  const BoxFormatSpec& f = formats[0];
  int orientation = 0;
  int best = -1;
  for (int o = 0; o < 2; ++o) {
    const Eigen::Vector2d c = cell(f, o);
    const int n = fit_count(a, c.x());
    if (n < 2) continue;
    const int total = n * fit_count(b, c.y());
    if (total > best) {
      best = total;
      orientation = o;
    }
  }
  if (best <= 0) return block(formats, a, b);
  const Eigen::Vector2d c = cell(f, orientation);
  const int n = fit_count(a, c.x());
  const int rows = fit_count(b, c.y());
  const bool shift_fits = n * c.x() + 0.5 * c.x() <= a + kEps;
  const double span = shift_fits ? n * c.x() + 0.5 * c.x() : n * c.x();
  const double x0 = 0.5 * (a - span);
  const double y0 = 0.5 * (b - rows * c.y());
  std::vector<PlacedBox> out;
  for (int j = 0; j < rows; ++j) {
    const bool odd = (j % 2) == 1;
    const int count = odd && !shift_fits ? n - 1 : n;
    const double start = x0 + (odd ? 0.5 * c.x() : 0.0);
    for (int i = 0; i < count; ++i)
      out.push_back({Eigen::Vector2d(start + (i + 0.5) * c.x(), y0 + (j + 0.5) * c.y()),
                     orientation == 0 ? 0.0 : kPi / 2.0, 0});
  }
  return out;
}

/// Four arms turned by 90 degrees about the centre of a square; a central hole of |arm_a - arm_b|.
/// want_hole: chimney (a hole of at least 40 % of the short side) instead of the tightest pinwheel.
/// The rest of the area beside the square is filled with a block.
std::vector<PlacedBox> pinwheel(const std::vector<BoxFormatSpec>& formats, double a, double b,
                                bool want_hole, Rng& rng) {
  const BoxFormatSpec& f = formats[0];
  struct Arm {
    int o, i, j;
    double s, hole;
  };
  std::vector<Arm> arms;
  for (int o = 0; o < 2; ++o)
    for (int i = 1; i <= 4; ++i)
      for (int j = 1; j <= 4; ++j) {
        const Eigen::Vector2d c = cell(f, o);
        const double arm_a = i * c.x();
        const double arm_b = j * c.y();
        const double s = arm_a + arm_b;
        if (s > std::min(a, b) + kEps) continue;
        arms.push_back({o, i, j, s, std::abs(arm_a - arm_b)});
      }
  if (arms.empty()) return block(formats, a, b);
  // A chimney's hole is at least 40 % of the short side but too small to hold a box.
  const double hole_limit = 0.4 * f.short_m;
  auto acceptable = [&](const Arm& x) {
    return want_hole ? x.hole >= hole_limit && x.hole < f.short_m - kEps : x.hole < hole_limit;
  };
  auto better = [&](const Arm& x, const Arm& y) {  // true when x is preferred
    const bool xa = acceptable(x), ya = acceptable(y);
    if (xa != ya) return xa;
    if (!xa && std::abs(x.hole - y.hole) > kEps) return want_hole ? x.hole > y.hole : x.hole < y.hole;
    if (std::abs(x.s - y.s) > kEps) return x.s > y.s;
    return want_hole ? x.hole > y.hole : x.hole < y.hole;
  };
  Arm arm = arms.front();
  for (const Arm& candidate : arms)
    if (better(candidate, arm)) arm = candidate;

  const Eigen::Vector2d c = cell(f, arm.o);
  const double s = arm.s;
  const bool square_left = rng.chance(0.5);
  const double sx = square_left ? 0.0 : a - s;
  const double sy = 0.5 * (b - s);
  const Eigen::Vector2d centre(sx + 0.5 * s, sy + 0.5 * s);
  std::vector<PlacedBox> out;
  for (int k = 0; k < 4; ++k) {
    const double angle = k * kPi / 2.0;
    const Eigen::Rotation2Dd rot(angle);
    for (int jj = 0; jj < arm.j; ++jj)
      for (int ii = 0; ii < arm.i; ++ii) {
        const Eigen::Vector2d p(sx + (ii + 0.5) * c.x(), sy + (jj + 0.5) * c.y());
        double yaw = (arm.o == 0 ? 0.0 : kPi / 2.0) + angle;
        yaw = std::fmod(yaw, kPi);
        out.push_back({centre + rot * (p - centre), yaw, 0});
      }
  }
  const double rest = a - s;
  if (rest > 0.0) {
    const double rx = square_left ? s : 0.0;
    fill_block(out, 0, f, best_orientation(f, rest, b), rx, 0.0, rest, b);
  }
  return out;
}

/// Two formats side by side: a block of the first beside a block of the second, the best cover.
std::vector<PlacedBox> mixed(const std::vector<BoxFormatSpec>& formats, double a, double b) {
  if (formats.size() < 2) return block(formats, a, b);
  const BoxFormatSpec& f0 = formats[0];
  const BoxFormatSpec& f1 = formats[1];
  double best_area = 0.0;
  std::vector<PlacedBox> best_boxes;
  for (int o = 0; o < 2; ++o) {
    const double step = cell(f0, o).x();
    for (int k = 1; k * step <= a + kEps; ++k) {
      const double w0 = k * step;
      const int n0 = block_count(f0, o, w0, b);
      const int o1 = best_orientation(f1, a - w0, b);
      const int n1 = block_count(f1, o1, a - w0, b);
      if (n0 == 0 || n1 == 0) continue;
      const double covered = n0 * f0.long_m * f0.short_m + n1 * f1.long_m * f1.short_m;
      if (covered <= best_area + kEps) continue;
      best_area = covered;
      best_boxes.clear();
      fill_block(best_boxes, 0, f0, o, 0.0, 0.0, w0, b);
      fill_block(best_boxes, 1, f1, o1, w0, 0.0, a - w0, b);
    }
  }
  return best_boxes.empty() ? block(formats, a, b) : best_boxes;
}

}  // namespace

std::vector<PlacedBox> make_pattern(PatternFamily family, const std::vector<BoxFormatSpec>& formats,
                                    double area_long_m, double area_short_m, Rng& rng) {
  std::vector<PlacedBox> boxes;
  if (formats.empty()) return boxes;
  const double a = area_long_m;
  const double b = area_short_m;
  switch (family) {
    case PatternFamily::kBlock: boxes = block(formats, a, b); break;
    case PatternFamily::kInterlock: boxes = interlock(formats, a, b); break;
    case PatternFamily::kBrick: boxes = brick(formats, a, b); break;
    case PatternFamily::kPinwheel: boxes = pinwheel(formats, a, b, false, rng); break;
    case PatternFamily::kChimney: boxes = pinwheel(formats, a, b, true, rng); break;
    case PatternFamily::kMixed: boxes = mixed(formats, a, b); break;
  }
  // Centre the layout's bounding box on the origin.
  Eigen::Vector2d lo(std::numeric_limits<double>::max(), std::numeric_limits<double>::max());
  Eigen::Vector2d hi = -lo;
  for (const PlacedBox& p : boxes) {
    const BoxFormatSpec& f = formats[static_cast<std::size_t>(p.format)];
    for (const Eigen::Vector2d& q : footprint_corners(p.center, p.yaw_rad, f.long_m, f.short_m)) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  }
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  for (PlacedBox& p : boxes) p.center -= mid;
  return boxes;
}

std::vector<Eigen::Vector2d> footprint_corners(const Eigen::Vector2d& center, double yaw_rad,
                                               double long_m, double short_m) {
  const Eigen::Vector2d u(std::cos(yaw_rad), std::sin(yaw_rad));
  const Eigen::Vector2d v(-u.y(), u.x());
  const Eigen::Vector2d hu = 0.5 * long_m * u;
  const Eigen::Vector2d hv = 0.5 * short_m * v;
  return {center - hu - hv, center + hu - hv, center + hu + hv, center - hu + hv};
}

bool footprints_overlap(const SimBox& a, const SimBox& b, double tolerance_m) {
  const auto ca = footprint_corners(a.center, a.yaw_rad, a.long_m, a.short_m);
  const auto cb = footprint_corners(b.center, b.yaw_rad, b.long_m, b.short_m);
  const double yaws[4] = {a.yaw_rad, a.yaw_rad + kPi / 2.0, b.yaw_rad, b.yaw_rad + kPi / 2.0};
  for (double yaw : yaws) {  // separating axis theorem
    const Eigen::Vector2d axis(std::cos(yaw), std::sin(yaw));
    double amin = 1e30, amax = -1e30, bmin = 1e30, bmax = -1e30;
    for (const auto& p : ca) {
      amin = std::min(amin, p.dot(axis));
      amax = std::max(amax, p.dot(axis));
    }
    for (const auto& p : cb) {
      bmin = std::min(bmin, p.dot(axis));
      bmax = std::max(bmax, p.dot(axis));
    }
    if (amax <= bmin + tolerance_m || bmax <= amin + tolerance_m) return false;
  }
  return true;
}

std::vector<std::size_t> removal_order(const std::vector<SimBox>& layer, RemovalMode mode, Rng& rng) {
  const std::size_t n = layer.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  if (n == 0) return order;
  std::vector<double> key(n, 0.0);
  const int axis = rng.chance(0.5) ? 1 : 0;        // rows run along the other axis
  const double sign = rng.chance(0.5) ? 1.0 : -1.0;  // which end is emptied first
  double short_min = 1e30;
  for (const SimBox& b : layer) short_min = std::min(short_min, b.short_m);
  const double row_pitch = 0.5 * short_min;
  Eigen::Vector2d lo(1e30, 1e30), hi(-1e30, -1e30);
  for (const SimBox& b : layer) {
    lo = lo.cwiseMin(b.center);
    hi = hi.cwiseMax(b.center);
  }
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& c = layer[i].center;
    switch (mode) {
      case RemovalMode::kRows:
      case RemovalMode::kColumns: {
        const int primary = mode == RemovalMode::kRows ? axis : 1 - axis;
        const double row = std::floor(sign * c[primary] / row_pitch);
        key[i] = row * 1000.0 + sign * c[1 - primary];
        break;
      }
      case RemovalMode::kCorner: {
        const Eigen::Vector2d corner(sign > 0 ? hi.x() : lo.x(), axis == 1 ? hi.y() : lo.y());
        key[i] = (c - corner).norm();
        break;
      }
      case RemovalMode::kRandom: key[i] = rng.uniform(); break;
      case RemovalMode::kHoles: {
        // Boxes away from the layer's outline go first, so the remaining boxes surround holes.
        const double border = std::min({c.x() - lo.x(), hi.x() - c.x(), c.y() - lo.y(), hi.y() - c.y()});
        key[i] = (border > 1e-3 ? 0.0 : 10.0) + rng.uniform();
        break;
      }
      case RemovalMode::kClusters:  // a band through the middle goes first: separate clusters remain
        key[i] = std::abs(c[axis] - mid[axis]) + 0.01 * rng.uniform();
        break;
    }
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return key[x] < key[y]; });
  return order;
}

}  // namespace palletd::sim::detail
