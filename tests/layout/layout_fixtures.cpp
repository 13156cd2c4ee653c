#include "layout_fixtures.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace palletd::layout_test {

namespace {

struct AxisRect {
  double x0, y0, x1, y1;
};

std::vector<AxisRect> rects_of(const KnownLayout& l) {
  std::vector<AxisRect> out;
  for (const auto& b : l.boxes) {
    const auto& f = l.formats[static_cast<std::size_t>(b.format)];
    const double w = b.long_along_x ? f.long_m : f.short_m;
    const double h = b.long_along_x ? f.short_m : f.long_m;
    out.push_back({b.x0, b.y0, b.x0 + w, b.y0 + h});
  }
  return out;
}

Eigen::Vector2d place(const KnownLayout& l, const Eigen::Vector2d& p) {
  const double c = std::cos(l.theta_rad), s = std::sin(l.theta_rad);
  return Eigen::Vector2d(c * p.x() - s * p.y(), s * p.x() + c * p.y()) + l.offset;
}

/// Spreads the boxes apart by gap_m per grid step (keeps their order, opens seams).
std::vector<AxisRect> spread(const KnownLayout& l) {
  std::vector<AxisRect> r = rects_of(l);
  if (l.gap_m <= 0) return r;
  std::vector<double> xs, ys;
  for (const auto& a : r) { xs.push_back(a.x0); ys.push_back(a.y0); }
  std::sort(xs.begin(), xs.end()); xs.erase(std::unique(xs.begin(), xs.end(), [](double a, double b) { return std::abs(a - b) < 1e-9; }), xs.end());
  std::sort(ys.begin(), ys.end()); ys.erase(std::unique(ys.begin(), ys.end(), [](double a, double b) { return std::abs(a - b) < 1e-9; }), ys.end());
  for (auto& a : r) {
    const auto ix = static_cast<double>(std::lower_bound(xs.begin(), xs.end(), a.x0 - 1e-9) - xs.begin());
    const auto iy = static_cast<double>(std::lower_bound(ys.begin(), ys.end(), a.y0 - 1e-9) - ys.begin());
    a.x0 += ix * l.gap_m; a.x1 += ix * l.gap_m;
    a.y0 += iy * l.gap_m; a.y1 += iy * l.gap_m;
  }
  return r;
}

}  // namespace

std::vector<Box2d> truth_boxes(const KnownLayout& l) {
  std::vector<Box2d> out;
  const auto rects = spread(l);
  for (std::size_t i = 0; i < rects.size(); ++i) {
    const auto& b = l.boxes[i];
    const auto& f = l.formats[static_cast<std::size_t>(b.format)];
    Box2d box;
    box.center = place(l, {(rects[i].x0 + rects[i].x1) / 2, (rects[i].y0 + rects[i].y1) / 2});
    box.yaw_rad = l.theta_rad + (b.long_along_x ? 0.0 : M_PI / 2);
    box.long_m = f.long_m;
    box.short_m = f.short_m;
    box.format = b.format;
    out.push_back(box);
  }
  return out;
}

std::vector<PolygonWithHoles> union_outline(const KnownLayout& l) {
  // Compressed coordinates, 4 pixels per compressed cell: a boundary pixel's centre rounds to
  // the cell boundary it belongs to, so the traced contour maps back exactly. Gaps are bridged.
  auto rects = spread(l);
  for (auto& r : rects) { r.x1 += l.gap_m; r.y1 += l.gap_m; }
  std::vector<double> xs, ys;
  for (const auto& r : rects) { xs.push_back(r.x0); xs.push_back(r.x1); ys.push_back(r.y0); ys.push_back(r.y1); }
  auto uniq = [](std::vector<double>& v) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end(), [](double a, double b) { return std::abs(a - b) < 1e-9; }), v.end());
  };
  uniq(xs); uniq(ys);
  auto idx = [](const std::vector<double>& v, double x) {
    return static_cast<int>(std::lower_bound(v.begin(), v.end(), x - 1e-9) - v.begin());
  };
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());
  cv::Mat mask = cv::Mat::zeros(4 * (ny + 1), 4 * (nx + 1), CV_8U);
  for (const auto& r : rects) {
    cv::rectangle(mask, cv::Point(4 * (idx(xs, r.x0) + 1), 4 * (idx(ys, r.y0) + 1)),
                  cv::Point(4 * (idx(xs, r.x1) + 1) - 1, 4 * (idx(ys, r.y1) + 1) - 1), cv::Scalar(255), cv::FILLED);
  }
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(mask, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);
  auto to_ring = [&](const std::vector<cv::Point>& c, bool hole) {
    Ring2d ring;
    for (const auto& p : c) {
      const int cx = static_cast<int>(std::lround(p.x / 4.0)) - 1, cy = static_cast<int>(std::lround(p.y / 4.0)) - 1;
      const Eigen::Vector2d q = place(l, {xs[static_cast<std::size_t>(std::clamp(cx, 0, nx - 1))],
                                          ys[static_cast<std::size_t>(std::clamp(cy, 0, ny - 1))]});
      if (ring.empty() || (ring.back() - q).norm() > 1e-9) ring.push_back(q);
    }
    while (ring.size() > 1 && (ring.front() - ring.back()).norm() < 1e-9) ring.pop_back();
    // Drop collinear vertices.
    Ring2d clean;
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const auto& a = ring[(i + ring.size() - 1) % ring.size()];
      const auto& b = ring[i];
      const auto& c2 = ring[(i + 1) % ring.size()];
      const Eigen::Vector2d d0 = b - a, d1 = c2 - b;
      if (std::abs(d0.x() * d1.y() - d0.y() * d1.x()) > 1e-12) clean.push_back(b);
    }
    const double a = signed_area(clean);
    if ((a < 0) != hole) std::reverse(clean.begin(), clean.end());
    return clean;
  };
  std::vector<PolygonWithHoles> out;
  for (std::size_t i = 0; i < contours.size(); ++i) {
    if (hierarchy[i][3] >= 0) continue;  // a hole, added with its parent
    PolygonWithHoles p;
    p.outer = to_ring(contours[i], false);
    for (int h = hierarchy[i][2]; h >= 0; h = hierarchy[static_cast<std::size_t>(h)][0]) {
      p.holes.push_back(to_ring(contours[static_cast<std::size_t>(h)], true));
    }
    out.push_back(p);
  }
  return out;
}

std::vector<PolygonWithHoles> perturb(const std::vector<PolygonWithHoles>& polygons, double amplitude_m,
                                      double chamfer_m, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amplitude_m, amplitude_m);
  auto ring_of = [&](const Ring2d& r) {
    Ring2d out;
    const std::size_t n = r.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector2d a = r[(i + n - 1) % n], b = r[i], c = r[(i + 1) % n];
      if (chamfer_m > 0) {
        out.push_back(b + (a - b).normalized() * chamfer_m);
        out.push_back(b + (c - b).normalized() * chamfer_m);
      } else {
        out.push_back(b);
      }
      // A mid-edge vertex so that the edge itself is not straight.
      out.push_back((b + c) / 2);
    }
    for (auto& p : out) {  // y before x, one draw per statement (the order gcc evaluated them in)
      const double dy = u(rng);
      const double dx = u(rng);
      p += Eigen::Vector2d(dx, dy);
    }
    return out;
  };
  std::vector<PolygonWithHoles> out;
  for (const auto& p : polygons) {
    PolygonWithHoles q;
    q.outer = ring_of(p.outer);
    for (const auto& h : p.holes) q.holes.push_back(ring_of(h));
    out.push_back(q);
  }
  return out;
}

SeamEvidence synthetic_seams(const KnownLayout& l, double cell_m, double half_width_m) {
  const auto truth = truth_boxes(l);
  const auto outline = union_outline(l);
  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const auto& p : outline) {
    for (const auto& v : p.outer) {
      bx0 = std::min(bx0, v.x()); bx1 = std::max(bx1, v.x());
      by0 = std::min(by0, v.y()); by1 = std::max(by1, v.y());
    }
  }
  SeamEvidence ev;
  ev.cell_m = cell_m;
  ev.origin_m = {bx0 - 0.02, by0 - 0.02};
  ev.width = static_cast<int>((bx1 - bx0 + 0.04) / cell_m) + 1;
  ev.height = static_cast<int>((by1 - by0 + 0.04) / cell_m) + 1;
  ev.seam.assign(static_cast<std::size_t>(ev.width) * static_cast<std::size_t>(ev.height), 0.f);
  std::size_t seamy = 0, inside = 0;
  const double reach = half_width_m + l.gap_m;
  for (int y = 0; y < ev.height; ++y) {
    for (int x = 0; x < ev.width; ++x) {
      const Eigen::Vector2d p = ev.origin_m + Eigen::Vector2d((x + 0.5) * cell_m, (y + 0.5) * cell_m);
      int near = 0;
      bool in_box = false;
      for (const auto& b : truth) {
        const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
        const Eigen::Vector2d d = p - b.center;
        const double qx = c * d.x() + s * d.y(), qy = -s * d.x() + c * d.y();
        const double hx = b.long_m / 2, hy = b.short_m / 2;
        if (std::abs(qx) <= hx + reach && std::abs(qy) <= hy + reach) ++near;
        if (std::abs(qx) <= hx - half_width_m && std::abs(qy) <= hy - half_width_m) in_box = true;
      }
      if (near > 0) ++inside;
      if (near >= 2 && !in_box) {
        ev.seam[static_cast<std::size_t>(y) * static_cast<std::size_t>(ev.width) + static_cast<std::size_t>(x)] = 1.f;
        ++seamy;
      }
    }
  }
  ev.strength = inside > 0 ? static_cast<double>(seamy) / static_cast<double>(inside) : 0.0;
  return ev;
}

SeamEvidence taped(SeamEvidence seams, const KnownLayout& layout) {
  constexpr float kBoard = 1000.f;
  constexpr double kTapeWidth_m = 0.048;
  const auto boxes = truth_boxes(layout);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.f, 20.f);  // the board's grain and the sensor's noise
  const std::size_t n = seams.seam.size();
  seams.tops.assign(n, 0.f);
  seams.tops_seen.assign(n, 0.f);
  for (int iy = 0; iy < seams.height; ++iy) {
    for (int ix = 0; ix < seams.width; ++ix) {
      const Eigen::Vector2d p = seams.origin_m + seams.cell_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      const auto c =
          static_cast<std::size_t>(iy) * static_cast<std::size_t>(seams.width) + static_cast<std::size_t>(ix);
      for (const auto& b : boxes) {
        const Eigen::Vector2d d = p - b.center;
        const double along = std::cos(b.yaw_rad) * d.x() + std::sin(b.yaw_rad) * d.y();
        const double across = -std::sin(b.yaw_rad) * d.x() + std::cos(b.yaw_rad) * d.y();
        if (std::abs(along) > b.long_m / 2 || std::abs(across) > b.short_m / 2) continue;
        seams.tops[c] = (std::abs(across) <= kTapeWidth_m / 2 ? 0.7f * kBoard : kBoard) + noise(rng);
        seams.tops_seen[c] = 1.f;
      }
    }
  }
  return seams;
}

std::vector<Eigen::Vector2f> layer_points(const KnownLayout& l, double pitch_m) {
  std::vector<Eigen::Vector2f> out;
  for (const auto& b : truth_boxes(l)) {
    const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
    for (double qx = -b.long_m / 2 + pitch_m / 2; qx < b.long_m / 2; qx += pitch_m) {
      for (double qy = -b.short_m / 2 + pitch_m / 2; qy < b.short_m / 2; qy += pitch_m) {
        out.emplace_back(static_cast<float>(b.center.x() + c * qx - s * qy),
                         static_cast<float>(b.center.y() + s * qx + c * qy));
      }
    }
  }
  return out;
}

double match_error_boxes(const std::vector<Box2d>& truth, const std::vector<Box2d>& found) {
  if (truth.size() != found.size()) return -1.0;
  std::vector<bool> used(found.size(), false);
  double worst = 0;
  for (const auto& t : truth) {
    double best = 1e9;
    std::size_t bj = found.size();
    for (std::size_t j = 0; j < found.size(); ++j) {
      if (used[j] || found[j].format != t.format) continue;
      double dyaw = std::fmod(std::abs(found[j].yaw_rad - t.yaw_rad), M_PI);
      dyaw = std::min(dyaw, M_PI - dyaw);
      if (dyaw > 2.0 * M_PI / 180.0) continue;
      const double d = (found[j].center - t.center).norm();
      if (d < best) { best = d; bj = j; }
    }
    if (bj == found.size() || best > 0.25 * t.short_m) return -1.0;
    used[bj] = true;
    worst = std::max(worst, best);
  }
  return worst;
}

bool inside_by(const Rect2d& r, double margin_m, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  return !(lo.x() < r.x0 + margin_m || lo.y() < r.y0 + margin_m || hi.x() > r.x1 - margin_m ||
           hi.y() > r.y1 - margin_m);
}

RefineInput packed_block_input(const Rect2d& outline, int cols, int rows, const BoxFormat& nominal,
                               const Eigen::Vector2d& origin_m, double cell_m,
                               const std::function<float(const SeamCell&)>& seam_share) {
  RefineInput in;
  in.layer.status = DetectionStatus::kOk;
  const Ring2d rectangle{{outline.x0, outline.y0}, {outline.x1, outline.y0}, {outline.x1, outline.y1},
                         {outline.x0, outline.y1}};
  in.layer.polygons.push_back(PolygonWithHoles{rectangle, {}});
  SeamEvidence& ev = in.seams;
  ev.cell_m = cell_m;
  ev.origin_m = origin_m;
  ev.width = static_cast<int>((outline.x1 - outline.x0 + 0.04) / cell_m) + 1;
  ev.height = static_cast<int>((outline.y1 - outline.y0 + 0.04) / cell_m) + 1;
  ev.seam.assign(static_cast<std::size_t>(ev.width) * static_cast<std::size_t>(ev.height), 0.f);
  std::size_t seamy = 0;
  for (int iy = 0; iy < ev.height; ++iy) {
    for (int ix = 0; ix < ev.width; ++ix) {
      const SeamCell cell{{ev.origin_m.x() + ix * cell_m, ev.origin_m.y() + iy * cell_m},
                          {ev.origin_m.x() + (ix + 0.5) * cell_m, ev.origin_m.y() + (iy + 0.5) * cell_m}};
      const float v = seam_share(cell);
      ev.seam[static_cast<std::size_t>(iy) * static_cast<std::size_t>(ev.width) +
              static_cast<std::size_t>(ix)] = v;
      if (v > 0.5f) ++seamy;
    }
  }
  ev.strength = static_cast<double>(seamy) / static_cast<double>(ev.seam.size());
  in.found.status = DetectionStatus::kOk;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      Box2d b;
      b.center = Eigen::Vector2d(outline.x0 + (c + 0.5) * nominal.long_m,
                                 outline.y0 + (r + 0.5) * nominal.short_m);
      b.yaw_rad = 0.0;
      b.long_m = nominal.long_m;
      b.short_m = nominal.short_m;
      b.format = 0;
      in.found.boxes.push_back({b, 1.0, 0, false, {}});
    }
  }
  return in;
}

KnownLayout block(int cols, int rows, double long_m, double short_m) {
  KnownLayout l{"block", {{long_m, short_m, "A"}}, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) l.boxes.push_back({c * long_m, r * short_m, 0, true});
  return l;
}

KnownLayout pinwheel(double L, double S, bool mirrored) {
  KnownLayout l{mirrored ? "pinwheel-mirrored" : "pinwheel", {{L, S, "A"}}, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  if (!mirrored) {
    l.boxes = {{0, 0, 0, true}, {L, 0, 0, false}, {S, L, 0, true}, {0, S, 0, false}};
  } else {
    l.boxes = {{0, 0, 0, false}, {S, 0, 0, true}, {L, S, 0, false}, {0, L, 0, true}};
  }
  return l;
}

KnownLayout brick() {
  // 1200 x 1000 with 400 x 300: two rows of three long boxes, then a row of four turned boxes.
  KnownLayout l{"brick", {{0.4, 0.3, "A"}}, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) l.boxes.push_back({c * 0.4, r * 0.3, 0, true});
  for (int c = 0; c < 4; ++c) l.boxes.push_back({c * 0.3, 0.6, 0, false});
  return l;
}

KnownLayout mixed_formats() {
  KnownLayout l{"mixed", {{0.4, 0.3, "A"}, {0.3, 0.2, "B"}}, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  for (int c = 0; c < 3; ++c) l.boxes.push_back({c * 0.4, 0.0, 0, true});
  for (int c = 0; c < 6; ++c) l.boxes.push_back({c * 0.2, 0.3, 1, false});
  return l;
}

KnownLayout l_shaped() {
  KnownLayout l = block(3, 3, 0.4, 0.3);
  l.name = "l-shaped";
  l.boxes.erase(l.boxes.begin() + 7, l.boxes.end());  // drop the last two of the top row
  return l;
}

KnownLayout clusters() {
  KnownLayout l{"clusters", {{0.4, 0.3, "A"}}, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  l.boxes = {{0, 0, 0, true}, {0.4, 0, 0, true},                    // a pair
             {1.0, 0, 0, false},                                     // a lone turned box
             {0, 0.5, 0, true}, {0, 0.8, 0, true}, {0.4, 0.5, 0, false}};  // an L of three
  return l;
}

KnownLayout grid_200x150(int n_boxes) {
  // The full layer (40 boxes, 1200 x 1000): four rows of six long boxes, then two rows of eight
  // turned boxes; fewer boxes = the first n of them (a partial layer).
  KnownLayout l{"grid200x150", {{0.2, 0.15, "S"}}, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 6; ++c) l.boxes.push_back({c * 0.2, r * 0.15, 0, true});
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 8; ++c) l.boxes.push_back({c * 0.15, 0.6 + r * 0.2, 0, false});
  l.boxes.resize(static_cast<std::size_t>(std::clamp(n_boxes, 1, 40)));
  return l;
}

}  // namespace palletd::layout_test
