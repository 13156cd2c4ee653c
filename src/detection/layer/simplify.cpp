// Stage 5b: a crust ring simplified to a polygon with reliable corners and fitted edges.
#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

/// Farthest a corner moves from its vertex to the crossing of its two long lines [pitches]:
/// beyond it the crossing is no blunted corner but a missing piece the samples would show.
constexpr double kMaxCornerPull = 10.0;
/// Widest angle [rad] by which a short step riser between two edges across it is snapped onto
/// the grid (its direction's uncertainty, atan(pitch / length), capped).
constexpr double kMaxRiserSnap = 20.0 * M_PI / 180.0;
/// Smallest simplification tolerance [m].
constexpr double kMinTolerance_m = 1e-4;
/// Smallest Douglas-Peucker tolerance [pitches]: the ring's border pixel centres stray about this
/// far from a straight edge's chord.
constexpr double kStaircase_pitches = 0.75;
/// Shortest Douglas-Peucker edge kept as an edge of its own [pitches] (and at least 2 tolerances).
constexpr double kMinEdge_pitches = 3.0;
/// How far beyond its edge a sample (or its border pixel) may lie and still be assigned to it
/// [pitches] (and at least the tolerance).
constexpr double kAssignReach_pitches = 1.5;
/// The ends of an edge, where its samples turn the corner, fit no line: this many pitches plus
/// kEndMargin_m at each end, at most kMaxEndShare of the edge.
constexpr double kEndMargin_pitches = 2.0;
constexpr double kEndMargin_m = 0.002;
constexpr double kMaxEndShare = 0.25;
/// A corner further than this from its Douglas-Peucker vertex falls back to the vertex
/// [pitches] (and at least kCornerFar_tols tolerances).
constexpr double kCornerFar_pitches = 4.0;
constexpr double kCornerFar_tols = 5.0;
/// Least spread of an edge's samples about its line [pitches]: where a border pixel lies within
/// its pixel, uniform over one pitch (1 / sqrt(12)).
constexpr double kQuantisation_pitches = 0.29;

double angle_between_dirs(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return std::acos(std::clamp(std::abs(a.dot(b)), 0.0, 1.0));  // 0..pi/2, sign ignored
}

double rms(const FittedLine& line) {
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

bool intersect(const FittedLine& a, const FittedLine& b, Eigen::Vector2d& out) {
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
    FittedLine before, after;
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

/// Polygon corner k: where lines k-1 and k meet, or the Douglas-Peucker vertex when they meet
/// far from it (nearly parallel lines).
Eigen::Vector2d corner_at(const std::vector<FittedLine>& lines, const std::vector<Eigen::Vector2d>& v,
                          std::size_t k, double far) {
  const FittedLine& before = lines[(k + lines.size() - 1) % lines.size()];
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
void recover_corners(std::vector<FittedLine>& lines, std::vector<Eigen::Vector2d>& v,
                     const std::vector<Eigen::Vector2d>& samples, double pitch_m, double far,
                     double grid_rad) {
  const double max_cos = std::sin(10.0 * M_PI / 180.0);
  // A long line is a fitted edge along the ring's grid; the edges between two of them may be
  // anything else (short, or off the grid: a pixel run).
  auto is_long = [&](const FittedLine& l) {
    if (!l.fitted || l.samples.size() < 5 || l.length < 4.0 * pitch_m) return false;
    const double a = std::atan2(l.dir.y(), l.dir.x()) - grid_rad;
    return std::abs(a - std::round(a / (M_PI / 2.0)) * (M_PI / 2.0)) < 6.0 * M_PI / 180.0;
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
        std::vector<FittedLine> kept_lines;
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

// ---- simplify_ring's phases ---------------------------------------------------------------------

/// Inverse variance of a fitted line's direction [rad^-2]: the spread of its samples along it,
/// sum (t - mean t)^2, over the square of their spread across it (their rms about the line, at
/// least `floor_m`).
double direction_weight(const FittedLine& line, double floor_m) {
  if (line.samples.empty()) return 0.0;
  double mean_t = 0.0;
  for (const auto& p : line.samples) mean_t += p.dot(line.dir);
  mean_t /= static_cast<double>(line.samples.size());
  double spread_t = 0.0;
  for (const auto& p : line.samples) {
    const double t = p.dot(line.dir) - mean_t;
    spread_t += t * t;
  }
  const double sigma = std::max(rms(line), floor_m);
  return spread_t / (sigma * sigma);
}

/// The scales one ring is simplified at.
struct RingScales {
  double pitch_m = 0.0;    ///< spacing of the border pixels [m]
  double tol_m = 0.0;      ///< simplification tolerance [m]
  double merge_rad = 0.0;  ///< lines closer than this in direction may be one [rad]
};

/// The ring's dominant grid direction (mean of 4 x the lines' angles, so modulo 90 degrees), and
/// the snapping of near-grid lines onto its axes.
class RingGrid {
 public:
  RingGrid(const std::vector<FittedLine>& lines, double snap_rad, double pitch_m)
      : angle_rad_(dominant_angle_rad(lines, pitch_m)), snap_rad_(snap_rad) {}

  [[nodiscard]] double angle_rad() const { return angle_rad_; }

  /// Unit direction of the grid axis nearest the direction `dir`.
  [[nodiscard]] Eigen::Vector2d axis_near(const Eigen::Vector2d& dir) const {
    const double a = std::atan2(dir.y(), dir.x());
    const double axis = angle_rad_ + std::round((a - angle_rad_) / (M_PI / 2.0)) * (M_PI / 2.0);
    return Eigen::Vector2d(std::cos(axis), std::sin(axis));
  }

  /// A line with at least 3 samples within max(snap_rad, widen_rad) of its nearest grid axis is
  /// turned onto that axis, through the mean of its samples.
  void snap(FittedLine& line, double widen_rad) const {
    if (line.samples.size() < 3 || snap_rad_ <= 0.0) return;
    const double a = std::atan2(line.dir.y(), line.dir.x());
    const double q = std::round((a - angle_rad_) / (M_PI / 2.0));
    const double target = angle_rad_ + q * M_PI / 2.0;
    if (std::abs(a - target) > std::max(snap_rad_, widen_rad)) return;
    line.dir = Eigen::Vector2d(std::cos(target), std::sin(target));
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : line.samples) mean += p;
    line.point = mean / static_cast<double>(line.samples.size());
  }

 private:
  /// Each fitted line weighs as the inverse variance of its direction (direction_weight): a long
  /// straight edge decides, and a ragged stretch that Douglas-Peucker cut into many short lines
  /// (a narrow gap between two pieces that a stereo camera smooths over) hardly counts, where
  /// weights by length let its pieces turn the grid by degrees. Without any fitted line, the
  /// lines count by their length.
  static double dominant_angle_rad(const std::vector<FittedLine>& lines, double pitch_m) {
    const double floor_m = std::max(kQuantisation_pitches * pitch_m, kMinTolerance_m);
    double c = 0.0, s4 = 0.0;
    auto add = [&](const FittedLine& line, double weight) {
      const double a = std::atan2(line.dir.y(), line.dir.x());
      c += weight * std::cos(4.0 * a);
      s4 += weight * std::sin(4.0 * a);
    };
    for (const auto& line : lines)
      if (line.fitted) add(line, direction_weight(line, floor_m));
    if (c == 0.0 && s4 == 0.0)
      for (const auto& line : lines) add(line, line.length);
    return std::atan2(s4, c) / 4.0;
  }

  double angle_rad_;
  double snap_rad_;
};

/// One line per polygon edge, from vertex k to vertex k + 1 (not fitted yet).
std::vector<FittedLine> edge_lines(const std::vector<Eigen::Vector2d>& v) {
  std::vector<FittedLine> lines(v.size());
  for (std::size_t k = 0; k < v.size(); ++k) {
    const Eigen::Vector2d a = v[k], b = v[(k + 1) % v.size()];
    lines[k].point = a;
    lines[k].length = (b - a).norm();
    lines[k].dir =
        lines[k].length > 0.0 ? Eigen::Vector2d((b - a) / lines[k].length) : Eigen::Vector2d::UnitX();
  }
  return lines;
}

/// Distance of q across the edge that starts at `start` along `line`; `along`: how far along the
/// edge q projects [m].
double across_edge(const FittedLine& line, const Eigen::Vector2d& start, const Eigen::Vector2d& q,
                   double& along) {
  const Eigen::Vector2d rel = q - start;
  along = rel.dot(line.dir);
  return std::abs(rel.x() * line.dir.y() - rel.y() * line.dir.x());
}

/// A sample goes to the nearest edge whose middle part it projects onto, among the edges its
/// border pixel (its origin) lies near: the pixel is within the ring's staircase (about a pitch
/// from the chord), while the sample itself may lie up to 1.5 (foreshortened) pixel steps beyond
/// it. Without origins: among the edges within assign_tol of the sample.
void assign_samples(std::vector<FittedLine>& lines, const std::vector<Eigen::Vector2d>& v,
                    const std::vector<Eigen::Vector2d>& samples,
                    const std::vector<Eigen::Vector2d>* sample_origins, double pitch_m, double assign_tol) {
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Eigen::Vector2d& s = samples[i];
    const Eigen::Vector2d& o = sample_origins != nullptr ? (*sample_origins)[i] : s;
    double best = sample_origins != nullptr ? std::numeric_limits<double>::infinity() : assign_tol;
    std::size_t best_k = lines.size();
    for (std::size_t k = 0; k < lines.size(); ++k) {
      double along = 0.0, along_o = 0.0;
      const double dist = across_edge(lines[k], v[k], s, along);
      const double margin =
          std::min(kEndMargin_pitches * pitch_m + kEndMargin_m, kMaxEndShare * lines[k].length);
      if (along < margin || along > lines[k].length - margin) continue;
      if (sample_origins != nullptr && across_edge(lines[k], v[k], o, along_o) > assign_tol) continue;
      if (dist < best) {
        best = dist;
        best_k = k;
      }
    }
    if (best_k < lines.size()) lines[best_k].samples.push_back(s);
  }
}

/// The riser of a step: a short edge between two edges across the grid axis it nearly follows
/// lies along that axis. Its fitted direction is uncertain by about a pitch over its length (its
/// ends lie anywhere within their border pixels; at a coarse pitch and a grid near 45 degrees a
/// 100 mm step is a few pixels): within that, up to kMaxRiserSnap, it is snapped.
void snap_risers(std::vector<FittedLine>& lines, const RingGrid& grid, const RingScales& scales) {
  for (std::size_t k = 0; k < lines.size() && lines.size() > 4; ++k) {
    const FittedLine& before = lines[(k + lines.size() - 1) % lines.size()];
    const FittedLine& after = lines[(k + 1) % lines.size()];
    const Eigen::Vector2d g = grid.axis_near(lines[k].dir);
    if (M_PI / 2.0 - angle_between_dirs(g, before.dir) > scales.merge_rad ||
        M_PI / 2.0 - angle_between_dirs(g, after.dir) > scales.merge_rad)
      continue;
    grid.snap(lines[k], std::min(std::atan2(scales.pitch_m, std::max(lines[k].length, 1e-9)), kMaxRiserSnap));
  }
}

/// Line b parallel to line a and in line with it (no step between them).
bool in_line(const FittedLine& a, const FittedLine& b, const RingScales& scales) {
  if (angle_between_dirs(a.dir, b.dir) >= scales.merge_rad) return false;
  const Eigen::Vector2d offset = b.point - a.point;
  return std::abs(offset.x() * a.dir.y() - offset.y() * a.dir.x()) <= 2.0 * scales.tol_m;
}

/// Lines a and b as one: their samples together, refitted; their lengths added.
FittedLine joined(const FittedLine& a, const FittedLine& b) {
  FittedLine m = a;
  m.samples.insert(m.samples.end(), b.samples.begin(), b.samples.end());
  m.length = a.length + b.length;
  fit_line(m);
  return m;
}

/// How far line b lies beside line a [m]: across the ring's grid axis when both lie near it (the
/// merged line is snapped onto it; a short piece's fitted direction is the least certain, and
/// measured across it a piece in line with its neighbour seems offset); off the grid, across a.
double lateral_offset(const FittedLine& a, const FittedLine& b, const RingGrid& grid, double merge_rad) {
  Eigen::Vector2d ref = a.dir;
  const Eigen::Vector2d g = grid.axis_near(ref);
  if (angle_between_dirs(g, a.dir) < merge_rad && angle_between_dirs(g, b.dir) < merge_rad) ref = g;
  const Eigen::Vector2d offset = b.point - a.point;
  return std::abs(offset.x() * ref.y() - offset.y() * ref.x());
}

/// Whether lines k and k + 1 (`merged`: the two as one) are one edge: when the union fits one
/// line (a split caused by noise), or when both are nearly parallel and nearly in line (no real
/// step between them). A long edge without samples of its own is no evidence of one line.
bool one_edge(const std::vector<FittedLine>& lines, std::size_t k, const FittedLine& merged,
              const RingGrid& grid, const RingScales& scales) {
  const std::size_t j = (k + 1) % lines.size();
  const FittedLine& a = lines[k];
  const FittedLine& b = lines[j];
  const double tol = scales.tol_m;
  const bool evidence = (a.samples.size() >= 3 && b.samples.size() >= 3) ||
                        std::min(a.length, b.length) < std::max(6.0 * scales.pitch_m, 4.0 * tol);
  const bool one_line = evidence && merged.samples.size() >= 6 && rms(merged) <= 0.5 * tol;
  const bool parallel = angle_between_dirs(a.dir, b.dir) < scales.merge_rad &&
                        lateral_offset(a, b, grid, scales.merge_rad) <= 2.0 * tol;
  if (!one_line && !parallel) return false;
  if (parallel || lines.size() <= 4) return true;
  // A short piece across its neighbour but in line with the line on its other side is the start
  // of that side (Douglas-Peucker cut the side at a kink of the ring): it joins that side.
  // Merged across the corner, its few samples hardly raise the union's rms, but the corner would
  // stay at the piece's far end.
  const FittedLine& after = lines[(j + 1) % lines.size()];
  const FittedLine& before = lines[(k + lines.size() - 1) % lines.size()];
  return !((b.length < a.length && in_line(b, after, scales)) ||
           (a.length < b.length && in_line(a, before, scales)));
}

/// Merges consecutive lines that are one edge (a split that is no corner), one pair at a time
/// from the start until no pair is; the merged line is snapped onto the grid.
void merge_collinear(std::vector<FittedLine>& lines, std::vector<Eigen::Vector2d>& v, const RingGrid& grid,
                     const RingScales& scales) {
  bool merged = true;
  while (merged && lines.size() > 3) {
    merged = false;
    for (std::size_t k = 0; k < lines.size() && lines.size() > 3; ++k) {
      const std::size_t j = (k + 1) % lines.size();
      FittedLine m = joined(lines[k], lines[j]);
      if (!one_edge(lines, k, m, grid, scales)) continue;
      grid.snap(m, 0.0);
      lines[k] = std::move(m);
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(j));
      v.erase(v.begin() + static_cast<std::ptrdiff_t>(j));
      merged = true;
      break;
    }
  }
}

/// The polygon: one corner per line, where it meets the line before it (see corner_at).
Ring2d corners_of(const std::vector<FittedLine>& lines, const std::vector<Eigen::Vector2d>& v, double far) {
  Ring2d out;
  out.reserve(lines.size());
  for (std::size_t k = 0; k < lines.size(); ++k) out.push_back(corner_at(lines, v, k, far));
  return out;
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
  const double tol = std::max(params.simplify_tolerance_m, kMinTolerance_m);
  const RingScales scales{pitch_m, tol, params.merge_angle_deg * M_PI / 180.0};
  // Corner candidates. The ring runs through border pixel centres: a straight edge is a
  // staircase whose centres stray up to about a pixel pitch from its chord (the fitted lines
  // place the edge).
  std::vector<Eigen::Vector2d> v = douglas_peucker(ring, std::max(tol, kStaircase_pitches * pitch_m));
  drop_short_edges(v, std::max(kMinEdge_pitches * pitch_m, 2.0 * tol), scales.merge_rad);
  if (v.size() < 3) return ring;

  // One line per edge, fitted to the samples that project onto its middle part.
  std::vector<FittedLine> lines = edge_lines(v);
  assign_samples(lines, v, samples, sample_origins, pitch_m, std::max(tol, kAssignReach_pitches * pitch_m));
  for (auto& line : lines) fit_line(line);

  // Near-grid lines snapped onto the grid, splits that are no corner merged, blunted corners
  // recovered.
  const RingGrid grid(lines, params.snap_angle_deg * M_PI / 180.0, pitch_m);
  for (auto& line : lines) grid.snap(line, 0.0);
  snap_risers(lines, grid, scales);
  merge_collinear(lines, v, grid, scales);
  const double far = std::max(kCornerFar_tols * tol, kCornerFar_pitches * pitch_m);
  recover_corners(lines, v, samples, pitch_m, far, grid.angle_rad());
  return corners_of(lines, v, far);
}

}  // namespace palletd::layer
