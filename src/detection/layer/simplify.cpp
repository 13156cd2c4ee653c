// Stage 5b: a crust ring simplified to a polygon with reliable corners and fitted edges.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Farthest a corner moves from its vertex to the crossing of its two long lines [pitches]:
/// beyond it the crossing is no blunted corner but a missing piece the samples would show.
constexpr double kMaxCornerPull = 10.0;
/// Widest angle [rad] by which a short step riser between two edges across it is snapped onto
/// the grid (its direction's uncertainty, atan(pitch / length), capped).
constexpr double kMaxRiserSnap = 20.0 * kPi / 180.0;

struct Line {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  Eigen::Vector2d dir = Eigen::Vector2d::UnitX();  // unit
  std::vector<Eigen::Vector2d> samples;
  double length = 0.0;
  bool fitted = false;
};

double angle_between_dirs(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return std::acos(std::clamp(std::abs(a.dot(b)), 0.0, 1.0));  // 0..pi/2, sign ignored
}

/// Total least squares line through samples; keeps `line.dir`'s sign.
void fit(Line& line) {
  if (line.samples.size() < 3) return;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& s : line.samples) mean += s;
  mean /= static_cast<double>(line.samples.size());
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& s : line.samples) cov += (s - mean) * (s - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  Eigen::Vector2d dir = eig.eigenvectors().col(1).normalized();
  if (dir.dot(line.dir) < 0.0) dir = -dir;
  line.point = mean;
  line.dir = dir;
  line.fitted = true;
}

double rms(const Line& line) {
  if (line.samples.empty()) return 0.0;
  double sum = 0.0;
  for (const auto& s : line.samples) {
    const Eigen::Vector2d rel = s - line.point;
    const double d = rel.x() * line.dir.y() - rel.y() * line.dir.x();
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(line.samples.size()));
}

double segment_distance(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& q) {
  const Eigen::Vector2d d = b - a;
  const double t = std::clamp((q - a).dot(d) / std::max(d.squaredNorm(), 1e-18), 0.0, 1.0);
  return (a + t * d - q).norm();
}

bool intersect(const Line& a, const Line& b, Eigen::Vector2d& out) {
  const double cross = a.dir.x() * b.dir.y() - a.dir.y() * b.dir.x();
  if (std::abs(cross) < 1e-9) return false;
  const Eigen::Vector2d d = b.point - a.point;
  const double t = (d.x() * b.dir.y() - d.y() * b.dir.x()) / cross;
  out = a.point + t * a.dir;
  return true;
}

std::vector<Eigen::Vector2d> douglas_peucker(const std::vector<Eigen::Vector2d>& ring, double tol) {
  std::vector<cv::Point2f> in;
  in.reserve(ring.size());
  for (const auto& p : ring) in.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  std::vector<cv::Point2f> out;
  cv::approxPolyDP(in, out, tol, true);
  std::vector<Eigen::Vector2d> v;
  v.reserve(out.size());
  for (const auto& p : out) v.emplace_back(static_cast<double>(p.x), static_cast<double>(p.y));
  return v;
}

/// Removes edges shorter than min_len: their two ends become one corner.
void drop_short_edges(std::vector<Eigen::Vector2d>& v, double min_len, double merge_rad) {
  bool changed = true;
  while (changed && v.size() > 3) {
    changed = false;
    const std::size_t n = v.size();
    std::size_t shortest = n;
    double shortest_len = min_len;
    for (std::size_t i = 0; i < n; ++i) {
      const double len = (v[(i + 1) % n] - v[i]).norm();
      if (len < shortest_len) {
        shortest_len = len;
        shortest = i;
      }
    }
    if (shortest == n) break;
    const std::size_t i = shortest, j = (i + 1) % n;
    Line before, after;
    before.point = v[(i + n - 1) % n];
    before.dir = (v[i] - before.point).normalized();
    after.point = v[j];
    after.dir = (v[(j + 1) % n] - v[j]).normalized();
    Eigen::Vector2d corner = 0.5 * (v[i] + v[j]);
    Eigen::Vector2d x;
    if (angle_between_dirs(before.dir, after.dir) > merge_rad && intersect(before, after, x) &&
        (x - corner).norm() < 3.0 * min_len)
      corner = x;
    v[i] = corner;
    v.erase(v.begin() + static_cast<std::ptrdiff_t>(j));
    changed = true;
  }
}

/// Distance of q to the outline of the rectangle (centre, axis u, half extents h), from inside
/// or outside.
double rect_boundary_distance(const Eigen::Vector2d& q, const Eigen::Vector2d& centre, const Eigen::Vector2d& u,
                              const Eigen::Vector2d& h) {
  const Eigen::Vector2d rel = q - centre;
  const double a = std::abs(rel.dot(u)), b = std::abs(rel.x() * u.y() - rel.y() * u.x());
  const double da = a - h.x(), db = b - h.y();
  if (da <= 0.0 && db <= 0.0) return std::min(-da, -db);
  return std::hypot(std::max(da, 0.0), std::max(db, 0.0));
}

/// One rectangle through the samples, when they show one: sides fitted to the samples along them
/// (the 2 pitches next to each corner left out) with one common direction. At a coarse pitch the
/// polygon's corners are blunted or its edges laid along pixel runs; the rectangle's are not.
/// Accepted only when 98 % of the samples lie within 1.25 pitches of its outline and each corner
/// within 1.75 pitches of the samples' hull (near a corner seen at a grazing angle the samples
/// stop more than a pitch short of it): a notch, a step between boxes or a corner cut by more
/// than 2.5 pitches along each side (a chamfered or damaged box) keeps the polygon.
/// Orientation: counter-clockwise.
bool fit_rectangle(const std::vector<Eigen::Vector2d>& samples, double pitch_m, Ring2d& rect) {
  if (samples.size() < 16) return false;
  std::vector<cv::Point2f> pts;
  pts.reserve(samples.size());
  for (const auto& p : samples) pts.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  const cv::RotatedRect box = cv::minAreaRect(pts);
  double theta = static_cast<double>(box.angle) * kPi / 180.0;
  Eigen::Vector2d centre(static_cast<double>(box.center.x), static_cast<double>(box.center.y));
  Eigen::Vector2d h(0.5 * static_cast<double>(box.size.width), 0.5 * static_cast<double>(box.size.height));
  if (std::min(h.x(), h.y()) < 2.0 * pitch_m) return false;
  const double margin = 2.0 * pitch_m;
  for (int iteration = 0; iteration < 3; ++iteration) {
    const Eigen::Vector2d u(std::cos(theta), std::sin(theta)), v(-u.y(), u.x());
    std::array<Line, 4> sides;  // +u, +v, -u, -v
    for (std::size_t k = 0; k < 4; ++k) sides[k].dir = (k % 2 == 0) ? v : u;
    for (const auto& s : samples) {
      const Eigen::Vector2d rel = s - centre;
      const double a = rel.dot(u), b = rel.dot(v);
      const std::array<double, 4> d{std::abs(a - h.x()), std::abs(b - h.y()), std::abs(a + h.x()), std::abs(b + h.y())};
      const auto k = static_cast<std::size_t>(std::min_element(d.begin(), d.end()) - d.begin());
      const double along = (k % 2 == 0) ? std::abs(b) : std::abs(a);
      const double half = (k % 2 == 0) ? h.y() : h.x();
      if (along > half - margin) continue;
      sides[k].samples.push_back(s);
    }
    double c4 = 0.0, s4 = 0.0;
    for (auto& side : sides) {
      if (side.samples.size() < 3) return false;
      fit(side);
      const double a = std::atan2(side.dir.y(), side.dir.x());
      const auto n = static_cast<double>(side.samples.size());
      c4 += n * std::cos(4.0 * a);
      s4 += n * std::sin(4.0 * a);
    }
    // The grid angle nearest the current one (angles modulo 90 degrees).
    const double grid = std::atan2(s4, c4) / 4.0;
    theta = grid + std::round((theta - grid) / (kPi / 2.0)) * (kPi / 2.0);
    const Eigen::Vector2d u2(std::cos(theta), std::sin(theta)), v2(-u2.y(), u2.x());
    std::array<double, 4> offset{};
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d axis = (k % 2 == 0) ? u2 : v2;
      offset[k] = (sides[k].point - centre).dot(axis);  // the mean of its samples
    }
    const double a_mid = 0.5 * (offset[0] + offset[2]), b_mid = 0.5 * (offset[1] + offset[3]);
    centre += a_mid * u2 + b_mid * v2;
    h = Eigen::Vector2d(0.5 * (offset[0] - offset[2]), 0.5 * (offset[1] - offset[3]));
    if (std::min(h.x(), h.y()) < 2.0 * pitch_m) return false;
  }
  const Eigen::Vector2d u(std::cos(theta), std::sin(theta)), v(-u.y(), u.x());
  std::size_t off = 0;
  for (const auto& s : samples)
    if (std::abs(rect_boundary_distance(s, centre, u, h)) > 1.25 * pitch_m) ++off;
  if (static_cast<double>(off) > 0.02 * static_cast<double>(samples.size())) return false;
  std::vector<cv::Point2f> hull;
  cv::convexHull(pts, hull);
  rect = {centre + h.x() * u + h.y() * v, centre - h.x() * u + h.y() * v, centre - h.x() * u - h.y() * v,
          centre + h.x() * u - h.y() * v};
  for (const auto& c : rect) {
    const cv::Point2f q(static_cast<float>(c.x()), static_cast<float>(c.y()));
    if (-cv::pointPolygonTest(hull, q, true) > 1.75 * pitch_m) return false;  // negative outside the hull
  }
  return true;
}

/// Polygon corner k: where lines k-1 and k meet, or the Douglas-Peucker vertex when they meet
/// far from it (nearly parallel lines).
Eigen::Vector2d corner_at(const std::vector<Line>& lines, const std::vector<Eigen::Vector2d>& v, std::size_t k,
                          double far) {
  const Line& before = lines[(k + lines.size() - 1) % lines.size()];
  Eigen::Vector2d x;
  if (intersect(before, lines[k], x) && (x - v[k]).norm() < far) return x;
  return v[k];
}

/// Right-angled corners blunted by the raster: two long fitted lines meeting at a near-right
/// angle with one to three edges between them (a short diagonal cutting the corner, an edge laid
/// along a pixel run) meet in one corner instead, when the samples there agree: the new corner
/// lies within 1.75 pitches of the hull of the samples around it, and nearly every sample
/// around it lies within 1.25 pitches of the two lines. A corner cut by more than 2.5 pitches
/// along each side (a chamfered or damaged box) or a step between boxes keeps its edges.
/// Two consecutive long lines whose crossing lies too far from their vertex for corner_at (the
/// short cut merged into one of them) meet at the crossing under the same test, up to
/// kMaxCornerPull pitches away.
void recover_corners(std::vector<Line>& lines, std::vector<Eigen::Vector2d>& v,
                     const std::vector<Eigen::Vector2d>& samples, double pitch_m, double far, double grid_rad) {
  const double max_cos = std::sin(10.0 * kPi / 180.0);
  // A long line is a fitted edge along the ring's grid; the edges between two of them may be
  // anything else (short, or off the grid: a pixel run).
  auto is_long = [&](const Line& l) {
    if (!l.fitted || l.samples.size() < 5 || l.length < 4.0 * pitch_m) return false;
    const double a = std::atan2(l.dir.y(), l.dir.x()) - grid_rad;
    return std::abs(a - std::round(a / (kPi / 2.0)) * (kPi / 2.0)) < 6.0 * kPi / 180.0;
  };
  bool changed = true;
  while (changed && lines.size() > 4) {
    changed = false;
    const std::size_t n = lines.size();
    for (std::size_t i = 0; i < n && !changed; ++i) {
      if (!is_long(lines[i])) continue;
      for (std::size_t m = 1; m <= 4 && !changed; ++m) {
        const std::size_t j = (i + m) % n;
        if (n - m + 1 < 4 || !is_long(lines[j])) continue;
        bool short_between = true;
        for (std::size_t t = 1; t < m; ++t) short_between = short_between && !is_long(lines[(i + t) % n]);
        if (!short_between || std::abs(lines[i].dir.dot(lines[j].dir)) > max_cos) continue;
        Eigen::Vector2d x;
        if (!intersect(lines[i], lines[j], x)) continue;
        double reach = 0.0;  // how far the replaced corners lie from the new one
        for (std::size_t t = 1; t <= m; ++t)
          reach = std::max(reach, (corner_at(lines, v, (i + t) % n, far) - x).norm());
        // m = 1: two long lines already consecutive whose corner fell back to the vertex (their
        // crossing lies farther than `far` from it: a blunted corner whose short edge merged
        // into a long one). No edge is dropped, only the corner moves: the samples decide.
        if (m == 1 && reach <= 1e-9) continue;  // the lines already meet at their crossing
        if (reach > (m == 1 ? kMaxCornerPull : 5.0) * pitch_m) continue;
        const double radius = reach + 2.0 * pitch_m;
        std::vector<cv::Point2f> near;
        std::size_t off = 0;
        for (const auto& q : samples) {
          if ((q - x).norm() > radius) continue;
          near.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
          const double d_in = segment_distance(x, x - radius * lines[i].dir, q);
          const double d_out = segment_distance(x, x + radius * lines[j].dir, q);
          if (std::min(d_in, d_out) > 1.25 * pitch_m) ++off;
        }
        if (near.size() < 3 || static_cast<double>(off) > 0.1 * static_cast<double>(near.size())) continue;
        std::vector<cv::Point2f> hull;
        cv::convexHull(near, hull);
        const cv::Point2f xp(static_cast<float>(x.x()), static_cast<float>(x.y()));
        if (-cv::pointPolygonTest(hull, xp, true) > 1.75 * pitch_m) continue;
        // Lines i+1 .. j-1 go with their start vertices; line j starts at the new corner.
        std::vector<Line> kept_lines;
        std::vector<Eigen::Vector2d> kept_v;
        for (std::size_t k = 0; k < n; ++k) {
          const std::size_t from_i = (k + n - i) % n;  // 0 for line i
          if (from_i >= 1 && from_i < m) continue;
          kept_lines.push_back(lines[k]);
          kept_v.push_back(from_i == m ? x : v[k]);
        }
        lines = std::move(kept_lines);
        v = std::move(kept_v);
        changed = true;
      }
    }
  }
}

}  // namespace

Ring2d simplify_ring(const std::vector<Eigen::Vector2d>& ring, const std::vector<Eigen::Vector2d>& samples,
                     double pitch_m, const ContourParams& params,
                     const std::vector<Eigen::Vector2d>* sample_origins) {
  if (sample_origins != nullptr && sample_origins->size() != samples.size()) sample_origins = nullptr;
  if (ring.size() < 4) return ring;
  Ring2d rect;
  if (fit_rectangle(samples, pitch_m, rect)) {
    if ((signed_area(ring) < 0.0) != (signed_area(rect) < 0.0)) std::reverse(rect.begin(), rect.end());
    return rect;
  }
  const double tol = std::max(params.simplify_tolerance_m, 1e-4);
  const double merge_rad = params.merge_angle_deg * kPi / 180.0;
  // The ring runs through border pixel centres: a straight edge is a staircase whose centres
  // stray up to about a pixel pitch from its chord (the fitted lines below place the edge).
  std::vector<Eigen::Vector2d> v = douglas_peucker(ring, std::max(tol, 0.75 * pitch_m));
  drop_short_edges(v, std::max(3.0 * pitch_m, 2.0 * tol), merge_rad);
  if (v.size() < 3) return ring;

  // One line per edge, fitted to the samples that project onto its middle part.
  std::vector<Line> lines(v.size());
  for (std::size_t k = 0; k < v.size(); ++k) {
    const Eigen::Vector2d a = v[k], b = v[(k + 1) % v.size()];
    lines[k].point = a;
    lines[k].length = (b - a).norm();
    lines[k].dir = lines[k].length > 0.0 ? Eigen::Vector2d((b - a) / lines[k].length) : Eigen::Vector2d::UnitX();
  }
  // A sample goes to the nearest edge whose middle part it projects onto, among the edges its
  // border pixel lies near: the pixel is within the ring's staircase (about a pitch from the
  // chord), while the sample itself may lie up to 1.5 (foreshortened) pixel steps beyond it.
  const double assign_tol = std::max(tol, 1.5 * pitch_m);
  auto distance_to = [&](std::size_t k, const Eigen::Vector2d& q, double& along) {
    const Eigen::Vector2d rel = q - v[k];
    along = rel.dot(lines[k].dir);
    return std::abs(rel.x() * lines[k].dir.y() - rel.y() * lines[k].dir.x());
  };
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Eigen::Vector2d& s = samples[i];
    const Eigen::Vector2d& o = sample_origins != nullptr ? (*sample_origins)[i] : s;
    double best = sample_origins != nullptr ? std::numeric_limits<double>::infinity() : assign_tol;
    std::size_t best_k = lines.size();
    for (std::size_t k = 0; k < lines.size(); ++k) {
      double along = 0.0, along_o = 0.0;
      const double dist = distance_to(k, s, along);
      const double margin = std::min(2.0 * pitch_m + 0.002, 0.25 * lines[k].length);
      if (along < margin || along > lines[k].length - margin) continue;
      if (sample_origins != nullptr && distance_to(k, o, along_o) > assign_tol) continue;
      if (dist < best) {
        best = dist;
        best_k = k;
      }
    }
    if (best_k < lines.size()) lines[best_k].samples.push_back(s);
  }
  for (auto& line : lines) fit(line);

  // Dominant grid direction of the ring (length-weighted mean of 4 * angle).
  double c = 0.0, s4 = 0.0;
  for (const auto& line : lines) {
    const double a = std::atan2(line.dir.y(), line.dir.x());
    c += line.length * std::cos(4.0 * a);
    s4 += line.length * std::sin(4.0 * a);
  }
  const double grid = std::atan2(s4, c) / 4.0;
  const double snap_rad = params.snap_angle_deg * kPi / 180.0;
  auto snap = [&](Line& line, double widen_rad) {
    if (line.samples.size() < 3 || snap_rad <= 0.0) return;
    const double a = std::atan2(line.dir.y(), line.dir.x());
    const double q = std::round((a - grid) / (kPi / 2.0));
    const double target = grid + q * kPi / 2.0;
    if (std::abs(a - target) > std::max(snap_rad, widen_rad)) return;
    line.dir = Eigen::Vector2d(std::cos(target), std::sin(target));
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : line.samples) mean += p;
    line.point = mean / static_cast<double>(line.samples.size());
  };
  for (auto& line : lines) snap(line, 0.0);
  // The riser of a step: a short edge between two edges across the grid axis it nearly follows
  // lies along that axis. Its fitted direction is uncertain by about a pitch over its length
  // (its ends lie anywhere within their border pixels; at a coarse pitch and a grid near 45
  // degrees a 100 mm step is a few pixels): within that, up to kMaxRiserSnap, it is snapped.
  for (std::size_t k = 0; k < lines.size() && lines.size() > 4; ++k) {
    const Line& before = lines[(k + lines.size() - 1) % lines.size()];
    const Line& after = lines[(k + 1) % lines.size()];
    const double a = std::atan2(lines[k].dir.y(), lines[k].dir.x());
    const double axis = grid + std::round((a - grid) / (kPi / 2.0)) * (kPi / 2.0);
    const Eigen::Vector2d g(std::cos(axis), std::sin(axis));
    if (kPi / 2.0 - angle_between_dirs(g, before.dir) > merge_rad ||
        kPi / 2.0 - angle_between_dirs(g, after.dir) > merge_rad)
      continue;
    snap(lines[k], std::min(std::atan2(pitch_m, std::max(lines[k].length, 1e-9)), kMaxRiserSnap));
  }

  // Line b parallel to line a and in line with it (no step between them) [lateral in m].
  auto in_line = [&](const Line& a, const Line& b) {
    if (angle_between_dirs(a.dir, b.dir) >= merge_rad) return false;
    const Eigen::Vector2d offset = b.point - a.point;
    return std::abs(offset.x() * a.dir.y() - offset.y() * a.dir.x()) <= 2.0 * tol;
  };
  // Merge consecutive near-parallel lines (a split that is no corner).
  bool merged = true;
  while (merged && lines.size() > 3) {
    merged = false;
    for (std::size_t k = 0; k < lines.size() && lines.size() > 3; ++k) {
      const std::size_t j = (k + 1) % lines.size();
      Line m = lines[k];
      m.samples.insert(m.samples.end(), lines[j].samples.begin(), lines[j].samples.end());
      m.length = lines[k].length + lines[j].length;
      fit(m);
      // One line when the union fits one (a split caused by noise), or when both are nearly
      // parallel and nearly in line (no real step between them).
      // (A long edge without samples of its own is no evidence of one line.)
      const bool evidence = (lines[k].samples.size() >= 3 && lines[j].samples.size() >= 3) ||
                            std::min(lines[k].length, lines[j].length) < std::max(6.0 * pitch_m, 4.0 * tol);
      const bool one_line = evidence && m.samples.size() >= 6 && rms(m) <= 0.5 * tol;
      // Offset across the ring's grid axis when both lie near it (the merged line is snapped
      // onto it): a short piece's fitted direction is the least certain, and measured across
      // it a piece in line with its neighbour seems offset. Off the grid: across line k.
      Eigen::Vector2d ref = lines[k].dir;
      {
        const double a = std::atan2(ref.y(), ref.x());
        const double axis = grid + std::round((a - grid) / (kPi / 2.0)) * (kPi / 2.0);
        const Eigen::Vector2d g(std::cos(axis), std::sin(axis));
        if (angle_between_dirs(g, lines[k].dir) < merge_rad && angle_between_dirs(g, lines[j].dir) < merge_rad) ref = g;
      }
      const Eigen::Vector2d offset = lines[j].point - lines[k].point;
      const double lateral = std::abs(offset.x() * ref.y() - offset.y() * ref.x());
      const bool parallel = angle_between_dirs(lines[k].dir, lines[j].dir) < merge_rad && lateral <= 2.0 * tol;
      if (!one_line && !parallel) continue;
      // A short piece across its neighbour but in line with the line on its other side is the
      // start of that side (Douglas-Peucker cut the side at a kink of the ring): it joins that
      // side. Merged across the corner, its few samples hardly raise the union's rms, but the
      // corner would stay at the piece's far end.
      if (!parallel && lines.size() > 4) {
        const Line& after = lines[(j + 1) % lines.size()];
        const Line& before = lines[(k + lines.size() - 1) % lines.size()];
        if ((lines[j].length < lines[k].length && in_line(lines[j], after)) ||
            (lines[k].length < lines[j].length && in_line(lines[k], before)))
          continue;
      }
      snap(m, 0.0);
      lines[k] = m;
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(j));
      v.erase(v.begin() + static_cast<std::ptrdiff_t>(j));
      merged = true;
      break;
    }
  }

  const double far = std::max(5.0 * tol, 4.0 * pitch_m);
  recover_corners(lines, v, samples, pitch_m, far, grid);
  Ring2d out;
  out.reserve(lines.size());
  for (std::size_t k = 0; k < lines.size(); ++k) out.push_back(corner_at(lines, v, k, far));
  return out;
}

}  // namespace palletd::layer
