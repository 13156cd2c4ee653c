// Stage 5b: a crust ring simplified to a polygon with reliable corners and fitted edges.
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

constexpr double kPi = 3.14159265358979323846;

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

}  // namespace

Ring2d simplify_ring(const std::vector<Eigen::Vector2d>& ring, const std::vector<Eigen::Vector2d>& samples,
                     double pitch_m, const ContourParams& params,
                     const std::vector<Eigen::Vector2d>* sample_origins) {
  if (sample_origins != nullptr && sample_origins->size() != samples.size()) sample_origins = nullptr;
  if (ring.size() < 4) return ring;
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
  auto snap = [&](Line& line) {
    if (line.samples.size() < 3 || snap_rad <= 0.0) return;
    const double a = std::atan2(line.dir.y(), line.dir.x());
    const double q = std::round((a - grid) / (kPi / 2.0));
    const double target = grid + q * kPi / 2.0;
    if (std::abs(a - target) > snap_rad) return;
    line.dir = Eigen::Vector2d(std::cos(target), std::sin(target));
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : line.samples) mean += p;
    line.point = mean / static_cast<double>(line.samples.size());
  };
  for (auto& line : lines) snap(line);

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
      const Eigen::Vector2d offset = lines[j].point - lines[k].point;
      const double lateral = std::abs(offset.x() * lines[k].dir.y() - offset.y() * lines[k].dir.x());
      const bool parallel = angle_between_dirs(lines[k].dir, lines[j].dir) < merge_rad && lateral <= 2.0 * tol;
      if (!one_line && !parallel) continue;
      snap(m);
      lines[k] = m;
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(j));
      v.erase(v.begin() + static_cast<std::ptrdiff_t>(j));
      merged = true;
      break;
    }
  }

  Ring2d out;
  out.reserve(lines.size());
  const double far = std::max(5.0 * tol, 4.0 * pitch_m);
  for (std::size_t k = 0; k < lines.size(); ++k) {
    const Line& before = lines[(k + lines.size() - 1) % lines.size()];
    Eigen::Vector2d x;
    if (intersect(before, lines[k], x) && (x - v[k]).norm() < far) {
      out.push_back(x);
    } else {
      out.push_back(v[k]);
    }
  }
  return out;
}

}  // namespace palletd::layer
