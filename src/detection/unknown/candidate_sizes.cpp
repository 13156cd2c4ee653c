// candidate_sizes(): carton sizes a layer of unknown cartons suggests. Seam lines across the
// layer, seen along the sides of each component's smallest enclosing rectangle, are spaced by
// whole cartons; so are the outline's opposite sides.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "palletd/detection/unknown_cartons.hpp"

namespace palletd {

namespace {

/// A component's smallest enclosing rectangle: axes u (its longer side) and v, extents along them.
struct RectAxes {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  ///< the corner at (u, v) = (0, 0) [m]
  Eigen::Vector2d u = Eigen::Vector2d::UnitX(), v = Eigen::Vector2d::UnitY();
  double length_u_m = 0.0, length_v_m = 0.0;
};

RectAxes rect_axes(const Ring2d& ring) {
  std::vector<cv::Point2f> points;
  for (const auto& p : ring) points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  const cv::RotatedRect r = cv::minAreaRect(points);
  RectAxes a;
  const double angle = r.angle * M_PI / 180.0;
  a.u = Eigen::Vector2d(std::cos(angle), std::sin(angle));
  a.v = Eigen::Vector2d(-a.u.y(), a.u.x());
  double u0 = 1e9, u1 = -1e9, v0 = 1e9, v1 = -1e9;
  for (const auto& p : ring) {
    u0 = std::min(u0, p.dot(a.u)), u1 = std::max(u1, p.dot(a.u));
    v0 = std::min(v0, p.dot(a.v)), v1 = std::max(v1, p.dot(a.v));
  }
  if (u1 - u0 < v1 - v0) {  // u along the longer side: turn the axes by 90 degrees
    const Eigen::Vector2d old_u = a.u;
    a.u = a.v;
    a.v = -old_u;
    const double nu0 = v0, nu1 = v1, nv0 = -u1, nv1 = -u0;
    u0 = nu0, u1 = nu1, v0 = nv0, v1 = nv1;
  }
  a.origin = u0 * a.u + v0 * a.v;
  a.length_u_m = u1 - u0;
  a.length_v_m = v1 - v0;
  return a;
}

/// Per position along one axis of the rectangle (cells of the seam raster's size): the share of
/// the layer's extent across it where a seam runs within two cells of that position.
struct SeamProfiles {
  std::vector<double> along_u, along_v;
};

SeamProfiles seam_profiles(const PolygonWithHoles& polygon, const SeamEvidence& seams, const RectAxes& a,
                           double margin_m) {
  const double cell = seams.cell_m;
  const int nu = static_cast<int>(a.length_u_m / cell) + 1, nv = static_cast<int>(a.length_v_m / cell) + 1;
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(nu * nv), 0), seam(inside.size(), 0);
  std::vector<cv::Point2f> contour;
  for (const auto& p : polygon.outer)
    contour.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  for (int iy = 0; iy < seams.height; ++iy) {
    for (int ix = 0; ix < seams.width; ++ix) {
      const Eigen::Vector2d p = seams.origin_m + cell * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      const Eigen::Vector2d q = p - a.origin;
      const int bu = static_cast<int>(std::floor(q.dot(a.u) / cell)),
                bv = static_cast<int>(std::floor(q.dot(a.v) / cell));
      if (bu < 0 || bv < 0 || bu >= nu || bv >= nv) continue;
      const cv::Point2f pt(static_cast<float>(p.x()), static_cast<float>(p.y()));
      if (cv::pointPolygonTest(contour, pt, true) < margin_m) continue;
      const auto k = static_cast<std::size_t>(bu * nv + bv);
      inside[k] = 1;
      if (seams.at(ix, iy) > 0.5F) seam[k] = 1;
    }
  }
  auto profile = [&](int n_along, int n_across, bool along_u) {
    std::vector<double> share(static_cast<std::size_t>(n_along), 0.0);
    for (int i = 0; i < n_along; ++i) {
      int rows = 0, hit = 0;
      for (int j = 0; j < n_across; ++j) {
        bool in = false, s = false;
        for (int d = std::max(0, i - 2); d <= std::min(n_along - 1, i + 2); ++d) {
          const auto k = static_cast<std::size_t>(along_u ? d * nv + j : j * nv + d);
          in = in || inside[k] != 0;
          s = s || seam[k] != 0;
        }
        rows += in ? 1 : 0;
        hit += s ? 1 : 0;
      }
      share[static_cast<std::size_t>(i)] = rows > 0 ? static_cast<double>(hit) / rows : 0.0;
    }
    return share;
  };
  return {profile(nu, nv, true), profile(nv, nu, false)};
}

/// Seam lines along a profile: positions [m from the rectangle's side] and their share, local
/// maxima above min_share at least 40 mm apart; the rectangle's two sides count as full lines.
std::vector<std::pair<double, double>> seam_lines(const std::vector<double>& share, double cell_m,
                                                  double length_m, double min_share) {
  std::vector<std::pair<double, double>> lines = {{0.0, 1.0}};
  const int suppress = static_cast<int>(0.04 / cell_m);
  for (int i = 0; i < static_cast<int>(share.size()); ++i) {
    const double s = share[static_cast<std::size_t>(i)];
    if (s < min_share) continue;
    bool peak = true;
    for (int d = std::max(0, i - suppress);
         d <= std::min(static_cast<int>(share.size()) - 1, i + suppress) && peak; ++d)
      peak = share[static_cast<std::size_t>(d)] < s || (share[static_cast<std::size_t>(d)] == s && d >= i);
    const double at_m = (i + 0.5) * cell_m;
    if (peak && at_m > 0.05 && at_m < length_m - 0.05) lines.emplace_back(at_m, s);
  }
  lines.emplace_back(length_m, 1.0);
  return lines;
}

struct Side {
  double length_m = 0.0;
  double support = 0.0;
};

/// Side lengths: spacings between seam lines one or two apart (two: a brick's offset rows; the
/// outline's two sides alone say nothing), and the side's length divided into 1..8 cartons
/// (weakly: any division tiles an outline).
void add_sides(const std::vector<std::pair<double, double>>& lines, double length_m,
               std::vector<Side>& sides) {
  for (std::size_t i = 0; i < lines.size(); ++i) {
    for (std::size_t j = i + 1; j < lines.size() && j <= i + 2; ++j) {
      if (i == 0 && j + 1 == lines.size()) continue;
      const double weight = std::min(lines[i].second, lines[j].second) * (j == i + 1 ? 1.0 : 0.5);
      sides.push_back({lines[j].first - lines[i].first, weight});
    }
  }
  for (int n = 1; n <= 8; ++n) sides.push_back({length_m / n, 0.05});
}

/// What is left of a rectangle's side after a cartons of a side already seen, in b cartons:
/// a pinwheel's or chimney's 400 + 300 along one side shows 400 once 300 is seen.
void add_remainders(const std::vector<double>& lengths_m, std::vector<Side>& sides) {
  const std::size_t seen = sides.size();
  for (std::size_t k = 0; k < seen; ++k) {
    if (sides[k].support < 0.2) continue;
    for (double length_m : lengths_m) {
      for (int a = 1; a <= 3; ++a) {
        for (int b = 1; b <= 3; ++b) {
          const double rest_m = (length_m - a * sides[k].length_m) / b;
          if (rest_m > 0.05) sides.push_back({rest_m, 0.1 * sides[k].support});
        }
      }
    }
  }
}

/// Sides within 8 mm of each other merged (support summed, length support-weighted).
std::vector<Side> merge_sides(std::vector<Side> sides) {
  std::sort(sides.begin(), sides.end(), [](const Side& x, const Side& y) { return x.length_m < y.length_m; });
  std::vector<Side> merged;
  for (const Side& s : sides) {
    if (!merged.empty() && s.length_m - merged.back().length_m < 0.008) {
      Side& m = merged.back();
      const double w = m.support + s.support;
      m.length_m = (m.length_m * m.support + s.length_m * s.support) / std::max(w, 1e-9);
      m.support = w;
    } else {
      merged.push_back(s);
    }
  }
  return merged;
}

/// A length is i cartons' long sides plus j short sides plus the gaps between them.
bool whole_cartons(double length_m, double long_m, double short_m, double max_gap_m,
                   double tolerance_m = 0.012) {
  for (int i = 0; i <= 8; ++i) {
    for (int j = 0; j <= 8 && i + j <= 10; ++j) {
      if (i + j == 0) continue;
      const double slack = length_m - (i * long_m + j * short_m);
      if (slack >= -tolerance_m && slack <= (i + j - 1) * max_gap_m + tolerance_m) return true;
    }
  }
  return false;
}

/// A component's rectangle and the seam lines seen across it, per axis.
struct Component {
  RectAxes rect;
  std::vector<std::pair<double, double>> lines_u, lines_v;
};

/// Share of the seam strength seen across an axis that a row of cartons of sides l and s (any
/// mix, gaps up to max_gap) puts a seam at, counted from either end; 1 when no seam is seen.
double explained_lines(const std::vector<std::pair<double, double>>& lines, double length_m, double l,
                       double s, double max_gap_m) {
  double seen = 0.0, explained = 0.0;
  for (std::size_t k = 1; k + 1 < lines.size(); ++k) {
    const auto [x, strength] = lines[k];
    seen += strength;
    constexpr double kLineTolerance_m = 0.008;
    const bool hit = whole_cartons(x, l, s, max_gap_m, kLineTolerance_m) ||
                     whole_cartons(length_m - x, l, s, max_gap_m, kLineTolerance_m);
    if (hit) explained += strength;
  }
  return seen > 0.0 ? explained / seen : 1.0;
}

/// Cartons of l x s whose rows make up a component's sides exactly like a block of i x j
/// cartons (either way round): the pattern most layers of one size are built of.
bool block_of(const RectAxes& a, double l, double s, double max_gap_m) {
  const auto rows = [&](double length_m, double side_m) {
    const double n = std::round(length_m / side_m);
    return n >= 1.0 && std::abs(length_m - n * side_m) <= 0.008 + (n - 1.0) * max_gap_m;
  };
  return (rows(a.length_u_m, l) && rows(a.length_v_m, s)) || (rows(a.length_u_m, s) && rows(a.length_v_m, l));
}

std::string name_of(const BoxFormat& f) {
  return std::to_string(static_cast<int>(std::lround(1e3 * f.long_m))) + "x" +
         std::to_string(static_cast<int>(std::lround(1e3 * f.short_m)));
}

}  // namespace

std::vector<SizeCandidate> candidate_sizes(const LayerResult& layer, const SeamEvidence& seams,
                                           const SizeRange& range, const UnknownCartonParams& params) {
  std::vector<Side> raw;
  std::vector<Component> components;
  for (const PolygonWithHoles& polygon : layer.polygons) {
    if (polygon.outer.size() < 3) continue;
    Component c{rect_axes(polygon.outer), {}, {}};
    SeamProfiles profiles;
    if (!seams.empty()) profiles = seam_profiles(polygon, seams, c.rect, params.outline_margin_m);
    c.lines_u = seam_lines(profiles.along_u, seams.cell_m, c.rect.length_u_m, params.min_seam_share);
    c.lines_v = seam_lines(profiles.along_v, seams.cell_m, c.rect.length_v_m, params.min_seam_share);
    add_sides(c.lines_u, c.rect.length_u_m, raw);
    add_sides(c.lines_v, c.rect.length_v_m, raw);
    components.push_back(std::move(c));
  }
  std::vector<double> lengths_m;
  for (const Component& c : components)
    lengths_m.insert(lengths_m.end(), {c.rect.length_u_m, c.rect.length_v_m});
  add_remainders(lengths_m, raw);
  const std::vector<Side> sides = merge_sides(std::move(raw));
  // Every pair of sides that tiles each component, ranked two ways: by the seam spacings that
  // propose its sides, and by the share of the seam lines seen that its rows explain (blocks of
  // it first, larger cartons first: smaller ones explain any line).
  std::vector<SizeCandidate> by_spacing, by_lines;
  for (const Side& l : sides) {
    for (const Side& s : sides) {
      if (!range.admits(l.length_m, s.length_m)) continue;
      double lines = 0.0;
      bool tiles = true, block = true;
      for (const Component& c : components) {
        const RectAxes& a = c.rect;
        tiles = tiles && whole_cartons(a.length_u_m, l.length_m, s.length_m, params.max_gap_m) &&
                whole_cartons(a.length_v_m, l.length_m, s.length_m, params.max_gap_m);
        block = block && block_of(a, l.length_m, s.length_m, params.max_gap_m);
        lines += explained_lines(c.lines_u, a.length_u_m, l.length_m, s.length_m, params.max_gap_m) +
                 explained_lines(c.lines_v, a.length_v_m, l.length_m, s.length_m, params.max_gap_m);
      }
      if (!tiles) continue;
      const BoxFormat f{l.length_m, s.length_m, "", 0.0};
      by_spacing.push_back({f, l.support + s.support});
      by_lines.push_back({f, lines + (block ? 1.0 : 0.0) + l.length_m * s.length_m});
    }
  }
  const auto better = [](const SizeCandidate& x, const SizeCandidate& y) { return x.support > y.support; };
  std::sort(by_spacing.begin(), by_spacing.end(), better);
  std::sort(by_lines.begin(), by_lines.end(), better);
  std::vector<SizeCandidate> out;
  const auto take = [&](const std::vector<SizeCandidate>& list, std::size_t n) {
    for (const SizeCandidate& c : list) {
      if (n == 0 || out.size() >= static_cast<std::size_t>(std::max(params.max_candidates, 0))) return;
      const bool seen = std::any_of(out.begin(), out.end(), [&](const SizeCandidate& o) {
        return std::abs(o.format.long_m - c.format.long_m) < 0.008 &&
               std::abs(o.format.short_m - c.format.short_m) < 0.008;
      });
      if (seen) continue;
      out.push_back(c);
      --n;
    }
  };
  const auto half = static_cast<std::size_t>(std::max(params.max_candidates, 0) + 1) / 2;
  take(by_spacing, half);
  take(by_lines, half);
  take(by_spacing, by_spacing.size());
  for (SizeCandidate& c : out) c.format.name = name_of(c.format);
  return out;
}

}  // namespace palletd
