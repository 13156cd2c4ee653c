// Robust edge-line fits and the joint least-squares fit of a layout's boxes (see refine_joint.hpp).
#include "refinement/refine_joint.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "palletd/core/statistics.hpp"

namespace palletd::layout_detail {

namespace {

/// The largest half side a fit may give: nominal + the tolerance, or the oversize share of it.
double half_upper(double half_nominal_m, const JointParams& params) {
  return half_nominal_m + std::max(0.5 * params.size_tolerance_m, params.max_oversize * half_nominal_m);
}

}  // namespace

EdgeLine fit_edge_line(const std::vector<Eigen::Vector2d>& samples, double t_ref, double floor_m, int min_samples,
                       double max_slope) {
  EdgeLine line;
  const auto n = samples.size();
  if (n < static_cast<std::size_t>(std::max(min_samples, 2))) return line;
  std::vector<double> p(n), w(n, 1.0), r(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = samples[i].y();
  double a = 0.0, b = 0.0, tm = t_ref;  // p = a + b (t - tm)
  double scale = floor_m;
  constexpr double kTukey = 4.685;
  // Tukey-reweighted least squares from a flat line through the median; with `flat` the slope
  // stays 0 (a robust location across the side).
  auto fit = [&](bool flat) {
    a = upper_median(p);
    b = 0.0;
    tm = t_ref;
    std::fill(w.begin(), w.end(), 1.0);
    for (int it = 0; it < 10; ++it) {
      for (std::size_t i = 0; i < n; ++i) r[i] = samples[i].y() - (a + b * (samples[i].x() - tm));
      std::vector<double> absr(n);
      for (std::size_t i = 0; i < n; ++i) absr[i] = std::abs(r[i]);
      // The first pass starts from a flat line: let its scale cover a real slope.
      scale = std::max(1.4826 * upper_median(absr), floor_m);
      for (std::size_t i = 0; i < n; ++i) {
        const double u = r[i] / (kTukey * scale);
        w[i] = std::abs(u) < 1.0 ? (1 - u * u) * (1 - u * u) : 0.0;
      }
      double sw = 0, st = 0, sp = 0;
      for (std::size_t i = 0; i < n; ++i) {
        sw += w[i];
        st += w[i] * samples[i].x();
        sp += w[i] * samples[i].y();
      }
      if (sw <= 0) return false;
      tm = st / sw;
      const double pm = sp / sw;
      double stt = 0, stp = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const double dt = samples[i].x() - tm;
        stt += w[i] * dt * dt;
        stp += w[i] * dt * (samples[i].y() - pm);
      }
      const double nb = flat || stt <= 1e-12 ? 0.0 : stp / stt;
      const bool converged = std::abs(pm - a) < 1e-6 * scale && std::abs(nb - b) < 1e-9;
      a = pm;
      b = nb;
      if (converged && it > 2) break;
    }
    return true;
  };
  if (!fit(false)) return line;
  // A side turned further than any box in a layer is a fit pulled by stray samples (the far end
  // of a seam band, a hole's edge): its position is the robust location instead, its turn unknown.
  const bool flat = std::abs(b) > max_slope;
  if (flat && !fit(true)) return line;
  int inliers = 0;
  double stt = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (w[i] <= 0) continue;
    ++inliers;
    stt += (samples[i].x() - tm) * (samples[i].x() - tm);
  }
  if (inliers < std::max(min_samples, 2)) return line;
  line.ok = true;
  line.scale_m = scale;
  line.inliers = inliers;
  line.slope = b;
  line.offset_m = a + b * (t_ref - tm);
  const double var_a = scale * scale / inliers;
  const double var_b = flat ? max_slope * max_slope : (stt > 1e-12 ? scale * scale / stt : 1.0);
  line.sigma_slope = flat ? std::numeric_limits<double>::infinity() : std::sqrt(var_b);
  line.sigma_offset_m = std::sqrt(var_a + (t_ref - tm) * (t_ref - tm) * var_b);
  return line;
}

namespace {

/// -1 (the floor beyond the side is seen) .. +1 (the side's wall hides a whole footprint of it):
/// the blend of the two pixel-footprint cases. Seen straight down or from the far side, the
/// floor shows; from the near side the wall hides view_slope * drop_m of it.
double facing_blend(double view_slope, double pitch_m, double drop_m) {
  const double ramp = drop_m > 0 ? pitch_m / drop_m : 0.0;
  if (!(ramp > 0)) return view_slope > 0 ? 1.0 : -1.0;
  return std::clamp(2.0 * view_slope / ramp - 1.0, -1.0, 1.0);
}

}  // namespace

double outline_footprint_correction(double view_slope, double pitch_m, double drop_m) {
  return -0.5 * pitch_m * facing_blend(view_slope, pitch_m, drop_m);
}

double seam_footprint_correction(double view_slope, double pitch_m, double drop_m) {
  return 0.5 * pitch_m * (1.0 - std::max(0.0, facing_blend(view_slope, pitch_m, drop_m)));
}

namespace {

/// How closely a pair of overlapping neighbours is made to touch [m].
constexpr double kSolid_m = 1e-4;

/// Cartons of one format on a layer come from one batch: their sizes along an axis are tied
/// (h_i - h_j = 0 +- batch_sigma_m per pair of the same nominal half size), so a box whose far
/// side is not seen (a seam pressed shut) takes the size its measured siblings show rather than
/// the nominal one: cartons run 1-5 % over their format, all of them alike.
void add_batch_ties(const std::vector<JointBox>& boxes, int axis, const JointParams& params, Eigen::MatrixXd& A) {
  if (!(params.batch_sigma_m > 0.0)) return;
  const auto n = static_cast<Eigen::Index>(boxes.size());
  const double half_sigma = 0.5 * params.batch_sigma_m;
  const double w = 1.0 / (half_sigma * half_sigma);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = i + 1; j < n; ++j) {
      const double hi = boxes[static_cast<std::size_t>(i)].half_nominal[axis];
      const double hj = boxes[static_cast<std::size_t>(j)].half_nominal[axis];
      if (std::abs(hi - hj) > 1e-6) continue;
      A(n + i, n + i) += w;
      A(n + j, n + j) += w;
      A(n + i, n + j) -= w;
      A(n + j, n + i) -= w;
    }
  }
}

/// The prior's spread of a half side around its nominal: size_sigma_m, or wider for long sides,
/// which run up to max_oversize over their format (half the oversize as one sigma) [m].
double half_size_prior_sigma_m(double half_nominal_m, const JointParams& params) {
  return std::max(0.5 * params.size_sigma_m, 0.5 * params.max_oversize * half_nominal_m);
}

/// One axis of the joint fit: unknowns c_0..c_{n-1}, h_0..h_{n-1} (centre and half size).
void solve_axis(std::vector<JointBox>& boxes, const std::vector<SideObservation>& sides,
                const std::vector<Contact>& contacts, const std::vector<Contact>& neighbours,
                const JointParams& params, int axis) {
  const auto n = static_cast<Eigen::Index>(boxes.size());
  if (n == 0) return;
  for (JointBox& b : boxes) b.sigma_center[axis] = params.anchor_sigma_m;  // kept if the fit fails
  std::vector<double> robust(sides.size(), 1.0);
  std::vector<bool> held(boxes.size(), false);
  std::vector<double> held_half(boxes.size(), 0.0);
  const double c_anchor = 1.0 / (params.anchor_sigma_m * params.anchor_sigma_m);
  auto c_size_of = [&](double half_nominal_m) {
    const double half_sigma = half_size_prior_sigma_m(half_nominal_m, params);
    return 1.0 / (half_sigma * half_sigma);
  };
  const double c_held = 1e12;
  std::vector<bool> pressed(neighbours.size(), false);  // overlapping neighbours made to touch
  std::vector<double> c0(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) c0[i] = boxes[i].center[axis];
  Eigen::VectorXd x(2 * n);
  Eigen::MatrixXd A;
  for (int round = 0; round < 12; ++round) {
    A = Eigen::MatrixXd::Zero(2 * n, 2 * n);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(2 * n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      A(i, i) += c_anchor;
      rhs(i) += c_anchor * c0[ui];
      const double prior =
          boxes[ui].half_prior[axis] > 0.0 ? boxes[ui].half_prior[axis] : boxes[ui].half_nominal[axis];
      const double hw = held[ui] ? c_held : c_size_of(boxes[ui].half_nominal[axis]);
      const double hv = held[ui] ? held_half[ui] : prior;
      A(n + i, n + i) += hw;
      rhs(n + i) += hw * hv;
    }
    for (std::size_t k = 0; k < sides.size(); ++k) {
      const SideObservation& s = sides[k];
      if (s.axis != axis) continue;
      const double w = robust[k] / (s.sigma_m * s.sigma_m);
      const Eigen::Index ic = s.box, ih = n + s.box;
      const double sg = s.sign;
      // c + sign * h = pos
      A(ic, ic) += w; A(ic, ih) += w * sg; A(ih, ic) += w * sg; A(ih, ih) += w;
      rhs(ic) += w * s.pos_m;
      rhs(ih) += w * sg * s.pos_m;
    }
    auto add_contact = [&](const Contact& c, double sigma_m) {
      // (c_b - h_b) - (c_a + h_a) = 0: coefficients on c_a, h_a, c_b, h_b
      const Eigen::Index idx[4] = {c.a, n + c.a, c.b, n + c.b};
      const double coef[4] = {-1.0, -1.0, 1.0, -1.0};
      const double w = 1.0 / (sigma_m * sigma_m);
      for (int p = 0; p < 4; ++p)
        for (int q = 0; q < 4; ++q) A(idx[p], idx[q]) += w * coef[p] * coef[q];
    };
    for (const Contact& c : contacts) {
      if (c.axis == axis) add_contact(c, c.sigma_m);
    }
    for (std::size_t k = 0; k < neighbours.size(); ++k) {
      if (pressed[k]) add_contact(neighbours[k], kSolid_m);
    }
    add_batch_ties(boxes, axis, params, A);
    x = A.ldlt().solve(rhs);
    if (!x.allFinite()) return;
    // Huber weights on the side observations (a wrong seam must not drag a whole row).
    bool changed = false;
    for (std::size_t k = 0; k < sides.size(); ++k) {
      const SideObservation& s = sides[k];
      if (s.axis != axis) continue;
      const double res = x(s.box) + s.sign * x(n + s.box) - s.pos_m;
      const double z = std::abs(res) / s.sigma_m;
      const double w = z > 3.0 ? 3.0 / z : 1.0;
      if (std::abs(w - robust[k]) > 0.05) changed = true;
      robust[k] = w;
    }
    // Solid boxes: a neighbour pair that overlaps by more than a fraction of its sigma touches.
    for (std::size_t k = 0; k < neighbours.size(); ++k) {
      const Contact& c = neighbours[k];
      if (c.axis != axis || pressed[k]) continue;
      const double gap = (x(c.b) - x(n + c.b)) - (x(c.a) + x(n + c.a));
      if (gap < -0.5 * c.sigma_m) {
        pressed[k] = true;
        changed = true;
      }
    }
    // Sizes outside the tolerance are held at its bound, once the robust weights and the solid
    // pairs have settled: a size pushed out by a side the Huber weights have yet to discount, or
    // by a pair about to be pressed, is no measurement of the box.
    const bool settled = !changed;
    for (Eigen::Index i = 0; i < n && settled; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const double nom = boxes[ui].half_nominal[axis];
      const double lo = nom - 0.5 * params.size_tolerance_m, hi = half_upper(nom, params);
      if (!held[ui] && (x(n + i) < lo || x(n + i) > hi)) {
        held[ui] = true;
        held_half[ui] = std::clamp(x(n + i), lo, hi);
        changed = true;
      }
    }
    if (!changed) break;
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto ui = static_cast<std::size_t>(i);
    boxes[ui].center[axis] = x(i);
    const double nom = boxes[ui].half_nominal[axis];
    boxes[ui].half[axis] = std::clamp(x(n + i), nom - 0.5 * params.size_tolerance_m, half_upper(nom, params));
  }
  // The centres' standard deviations: the diagonal of the inverse normal matrix (sides, contacts
  // and priors with their sigmas; the Huber weights and held sizes of the last round).
  const Eigen::MatrixXd cov = A.ldlt().solve(Eigen::MatrixXd::Identity(2 * n, 2 * n));
  for (Eigen::Index i = 0; i < n; ++i) {
    boxes[static_cast<std::size_t>(i)].sigma_center[axis] = std::sqrt(std::max(0.0, cov(i, i)));
    boxes[static_cast<std::size_t>(i)].sigma_half[axis] = std::sqrt(std::max(0.0, cov(n + i, n + i)));
  }
}

/// The batch's half size for each nominal half size, from the first pass's fitted halves along
/// both axes that the frame measured (sigma under half the prior's; inverse-variance mean):
/// pairs (nominal, batch). A nominal size no box measured has none.
std::vector<std::pair<double, double>> batch_halves(const std::vector<JointBox>& fitted,
                                                    const JointParams& params) {
  std::vector<std::pair<double, double>> out;
  std::vector<std::pair<double, double>> sums;  // (sum w h, sum w) per entry of out
  for (const JointBox& b : fitted) {
    for (int a = 0; a < 2; ++a) {
      const double nominal = b.half_nominal[a];
      const double prior_sigma = half_size_prior_sigma_m(nominal, params);
      const double sigma = b.sigma_half[a];
      if (!(sigma > 0.0) || sigma > 0.5 * prior_sigma) continue;
      const auto it = std::find_if(out.begin(), out.end(),
                                   [&](const auto& e) { return std::abs(e.first - nominal) < 1e-6; });
      const std::size_t k = it == out.end() ? out.size() : static_cast<std::size_t>(it - out.begin());
      if (it == out.end()) {
        out.emplace_back(nominal, 0.0);
        sums.emplace_back(0.0, 0.0);
      }
      const double w = 1.0 / (sigma * sigma);
      sums[k].first += w * b.half[a];
      sums[k].second += w;
    }
  }
  for (std::size_t k = 0; k < out.size(); ++k) out[k].second = sums[k].first / sums[k].second;
  return out;
}

}  // namespace

void solve_joint(std::vector<JointBox>& boxes, const std::vector<SideObservation>& sides,
                 const std::vector<Contact>& contacts, const JointParams& params,
                 const std::vector<Contact>& neighbours) {
  const std::vector<JointBox> start = boxes;
  solve_axis(boxes, sides, contacts, neighbours, params, 0);
  solve_axis(boxes, sides, contacts, neighbours, params, 1);
  const std::vector<std::pair<double, double>> batch = batch_halves(boxes, params);
  if (batch.empty()) return;
  std::vector<JointBox> second = start;
  for (JointBox& b : second) {
    for (int a = 0; a < 2; ++a) {
      for (const auto& [nominal, half] : batch)
        if (std::abs(b.half_nominal[a] - nominal) < 1e-6) b.half_prior[a] = half;
    }
  }
  solve_axis(second, sides, contacts, neighbours, params, 0);
  solve_axis(second, sides, contacts, neighbours, params, 1);
  boxes = std::move(second);
}

}  // namespace palletd::layout_detail
