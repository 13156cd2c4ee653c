// Side samples for the refinement (side_samples.hpp).
#include "refinement/side_samples.hpp"

#include <algorithm>
#include <cmath>

namespace palletd::layout_detail {

namespace {

/// Bilinear seam value at a layer point (0 outside the raster).
double seam_at(const SeamEvidence& ev, const Eigen::Vector2d& p) {
  const double fx = (p.x() - ev.origin_m.x()) / ev.cell_m - 0.5, fy = (p.y() - ev.origin_m.y()) / ev.cell_m - 0.5;
  if (!(fx >= 0 && fy >= 0 && fx < ev.width - 1 && fy < ev.height - 1)) return 0.0;
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  const double ax = fx - ix, ay = fy - iy;
  return (1 - ay) * ((1 - ax) * ev.at(ix, iy) + ax * ev.at(ix + 1, iy)) +
         ay * ((1 - ax) * ev.at(ix, iy + 1) + ax * ev.at(ix + 1, iy + 1));
}

}  // namespace

SideRef side_of(const JointBox& b, int axis, int sign, double margin_m) {
  SideRef s;
  s.axis = axis;
  s.sign = sign;
  const int o = 1 - axis;
  s.pos = b.center[axis] + sign * b.half[axis];
  s.t_ref = b.center[o];
  s.lo = b.center[o] - b.half[o] + margin_m;
  s.hi = b.center[o] + b.half[o] - margin_m;
  return s;
}

/// Outline side: per slice along the side, walk the box's own layer points outward from inside
/// the box and stop at the first gap (no points over 2.5 footprints); the edge is the last point
/// plus half a pixel, plus `shift` (the footprint correction). Where `rim` holds mixed pixels
/// just beyond that last point (x, y in the frame, top share), the edge lies within their
/// footprint by their top share instead (no correction: the share measures it). The edge may lie
/// up to window_m beyond the current side (points are read a gap further to see it end). Samples
/// (t, p) in the frame.
std::vector<Eigen::Vector2d> outline_samples(const SideRef& s, const std::vector<Eigen::Vector2d>& local,
                                             const std::vector<Eigen::Vector3d>* rim, double pitch_m,
                                             double window_m, double window_in_m, double shift) {
  std::vector<Eigen::Vector2d> out;
  if (s.hi <= s.lo) return out;
  const double slice = 1.5 * pitch_m, gap = 2.5 * pitch_m;
  const int n = std::max(1, static_cast<int>((s.hi - s.lo) / slice));
  std::vector<std::vector<double>> across(static_cast<std::size_t>(n));
  std::vector<std::vector<Eigen::Vector2d>> mixed(static_cast<std::size_t>(n));  // (u, top share)
  const int o = 1 - s.axis;
  // The slice of a frame point along the side and its distance outward from the current side
  // [m]; false outside the stretch or the window.
  auto place = [&](double x, double y, std::size_t* k, double* u) {
    const Eigen::Vector2d q(x, y);
    const double t = q[o];
    if (t < s.lo || t >= s.hi) return false;
    *u = s.sign * (q[s.axis] - s.pos);
    if (*u < -window_in_m || *u > window_m + gap) return false;
    *k = static_cast<std::size_t>(std::min(n - 1, static_cast<int>((t - s.lo) / (s.hi - s.lo) * n)));
    return true;
  };
  std::size_t slot = 0;
  double out_m = 0.0;
  for (const auto& q : local) {
    if (place(q.x(), q.y(), &slot, &out_m)) across[slot].push_back(out_m);
  }
  if (rim != nullptr) {
    for (const auto& r : *rim) {
      if (place(r.x(), r.y(), &slot, &out_m)) mixed[slot].emplace_back(out_m, r.z());
    }
  }
  for (std::size_t k = 0; k < across.size(); ++k) {
    auto& v = across[k];
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    if (v.front() > -window_in_m + gap) continue;  // the slice does not start on the box top
    double edge = v.front();
    for (std::size_t i = 1; i < v.size() && v[i] - edge < gap; ++i) edge = v[i];
    if (edge > window_m) continue;  // the edge is not seen within the window
    // The mixed pixels next beyond the last point: the edge lies in their footprint.
    double sum = 0.0;
    int count = 0;
    for (const auto& m : mixed[k]) {
      if (m.x() <= edge || m.x() > edge + slice) continue;
      sum += m.x() + (m.y() - 0.5) * pitch_m;
      ++count;
    }
    const double at = count > 0 ? sum / count : edge + 0.5 * pitch_m + shift;
    const double t = s.lo + (static_cast<double>(k) + 0.5) * (s.hi - s.lo) / n;
    out.emplace_back(t, s.pos + s.sign * at);
  }
  return out;
}

/// Shared side: per slice, walk the seam raster outward from inside the box to where it first
/// reaches 0.5 (the box's own edge of the seam band; sub-cell by linear interpolation).
std::vector<Eigen::Vector2d> seam_samples(const SideRef& s, const SeamEvidence& ev, const LayoutFrame& frame,
                                          double window_m, double window_in_m) {
  std::vector<Eigen::Vector2d> out;
  if (s.hi <= s.lo) return out;
  const double step = ev.cell_m;
  const int n = std::max(1, static_cast<int>((s.hi - s.lo) / step));
  const int o = 1 - s.axis;
  Eigen::Vector2d dir_u = Eigen::Vector2d::Zero();
  dir_u[s.axis] = s.sign;
  const Eigen::Vector2d du = frame.to_layer(dir_u) - frame.to_layer(Eigen::Vector2d::Zero());
  for (int k = 0; k < n; ++k) {
    const double t = s.lo + (k + 0.5) * (s.hi - s.lo) / n;
    Eigen::Vector2d q;
    q[s.axis] = s.pos;
    q[o] = t;
    const Eigen::Vector2d base = frame.to_layer(q);
    double u = -window_in_m;
    double prev = seam_at(ev, base + u * du);
    if (prev >= 0.5) continue;  // starts in a seam: no box top to walk from
    for (u += step; u <= window_m; u += step) {
      const double v = seam_at(ev, base + u * du);
      if (v >= 0.5) {
        const double cross = u - step + step * (0.5 - prev) / (v - prev);
        out.emplace_back(t, s.pos + s.sign * cross);
        break;
      }
      prev = v;
    }
  }
  return out;
}

}  // namespace palletd::layout_detail
