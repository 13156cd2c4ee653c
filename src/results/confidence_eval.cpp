#include "palletd/results/confidence_eval.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Dense>

namespace palletd {

double roc_auc(const std::vector<double>& scores, const std::vector<bool>& right) {
  // Mann-Whitney U from the ranks of the scores (average ranks for ties).
  const std::size_t n = scores.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return scores[a] < scores[b]; });
  double rank_sum = 0.0;
  std::size_t pos = 0, n_right = 0;
  for (std::size_t i = 0; i < n; i = pos) {
    pos = i;
    while (pos < n && scores[order[pos]] == scores[order[i]]) ++pos;
    const double avg_rank = 0.5 * static_cast<double>(i + 1 + pos);  // ranks i+1 .. pos
    for (std::size_t k = i; k < pos; ++k) {
      if (right[order[k]]) {
        rank_sum += avg_rank;
        ++n_right;
      }
    }
  }
  const std::size_t n_wrong = n - n_right;
  if (n_right == 0 || n_wrong == 0) return 0.0;
  const double nr = static_cast<double>(n_right), nw = static_cast<double>(n_wrong);
  return (rank_sum - nr * (nr + 1.0) / 2.0) / (nr * nw);
}

std::vector<ReliabilityBin> reliability_bins(const std::vector<double>& scores,
                                             const std::vector<bool>& right, int bins) {
  std::vector<ReliabilityBin> out(static_cast<std::size_t>(std::max(1, bins)));
  std::vector<double> right_n(out.size(), 0.0);
  for (std::size_t b = 0; b < out.size(); ++b) {
    out[b].lo = static_cast<double>(b) / static_cast<double>(out.size());
    out[b].hi = static_cast<double>(b + 1) / static_cast<double>(out.size());
  }
  for (std::size_t i = 0; i < scores.size(); ++i) {
    const double s = std::clamp(scores[i], 0.0, 1.0);
    const auto b = std::min(out.size() - 1, static_cast<std::size_t>(s * static_cast<double>(out.size())));
    ++out[b].n;
    out[b].mean_score += s;
    if (right[i]) right_n[b] += 1.0;
  }
  for (std::size_t b = 0; b < out.size(); ++b) {
    if (out[b].n == 0) continue;
    out[b].mean_score /= static_cast<double>(out[b].n);
    out[b].right_share = right_n[b] / static_cast<double>(out[b].n);
  }
  return out;
}

std::vector<ReliabilityBin> score_deciles(const std::vector<double>& scores, const std::vector<bool>& right,
                                          int groups) {
  std::vector<std::size_t> order(scores.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return scores[a] < scores[b]; });
  std::vector<ReliabilityBin> out;
  const auto g = static_cast<std::size_t>(std::max(1, groups));
  for (std::size_t k = 0; k < g; ++k) {
    const std::size_t first = k * order.size() / g, last = (k + 1) * order.size() / g;
    if (first == last) continue;
    ReliabilityBin b;
    b.lo = scores[order[first]];
    b.hi = scores[order[last - 1]];
    b.n = last - first;
    double right_n = 0.0;
    for (std::size_t i = first; i < last; ++i) {
      b.mean_score += scores[order[i]];
      if (right[order[i]]) right_n += 1.0;
    }
    b.mean_score /= static_cast<double>(b.n);
    b.right_share = right_n / static_cast<double>(b.n);
    out.push_back(b);
  }
  return out;
}

ScoreReport score_report(const std::vector<double>& scores, const std::vector<bool>& right,
                         std::size_t min_bin) {
  ScoreReport r;
  r.items = scores.size();
  r.right = static_cast<std::size_t>(std::count(right.begin(), right.end(), true));
  r.auc = roc_auc(scores, right);
  r.bins = reliability_bins(scores, right);
  for (const ReliabilityBin& b : r.bins) {
    if (b.n >= min_bin) r.max_bin_gap = std::max(r.max_bin_gap, std::abs(b.right_share - b.mean_score));
  }
  r.deciles = score_deciles(scores, right);
  for (const ReliabilityBin& b : r.deciles)
    r.max_decile_gap = std::max(r.max_decile_gap, std::abs(b.right_share - b.mean_score));
  for (std::size_t i = 0; i < scores.size(); ++i) {
    if (scores[i] < 0.9) continue;
    ++r.high;
    if (right[i]) ++r.high_right;
  }
  return r;
}

ConfidenceReport confidence_report(const std::vector<FrameEval>& frames, std::size_t min_bin) {
  std::vector<double> box_scores, layout_scores;
  std::vector<bool> box_right, layout_exact;
  for (const FrameEval& f : frames) {
    for (const BoxEval& b : f.boxes) {
      box_scores.push_back(b.score);
      box_right.push_back(b.right);
    }
    if (f.boxes.empty()) continue;
    layout_scores.push_back(f.layout_confidence);
    layout_exact.push_back(f.exact);
  }
  return {score_report(box_scores, box_right, min_bin), score_report(layout_scores, layout_exact, min_bin)};
}

LogisticFit fit_logistic(const std::vector<std::vector<double>>& x, const std::vector<bool>& y, double l2) {
  LogisticFit fit;
  if (x.empty()) return fit;
  const auto n = static_cast<Eigen::Index>(x.size()), k = static_cast<Eigen::Index>(x[0].size());
  Eigen::MatrixXd X(n, k);
  Eigen::VectorXd t(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < k; ++j)
      X(i, j) = x[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
    t(i) = y[static_cast<std::size_t>(i)] ? 1.0 : 0.0;
  }
  Eigen::VectorXd penalty = Eigen::VectorXd::Constant(k, l2 * static_cast<double>(n));
  penalty(0) = 0.0;
  Eigen::VectorXd w = Eigen::VectorXd::Zero(k);
  for (fit.iterations = 1; fit.iterations <= 100; ++fit.iterations) {
    const Eigen::VectorXd p = ((-(X * w).array()).exp() + 1.0).inverse().matrix();
    const Eigen::VectorXd s = (p.array() * (1.0 - p.array())).max(1e-9).matrix();
    // Newton step on the penalised log-likelihood: (X' S X + P) dw = X'(t - p) - P w.
    Eigen::MatrixXd H = X.transpose() * s.asDiagonal() * X;
    H.diagonal() += penalty;
    const Eigen::VectorXd g = X.transpose() * (t - p) - penalty.cwiseProduct(w);
    const Eigen::VectorXd step = H.ldlt().solve(g);
    if (!step.allFinite()) break;
    w += step;
    if (step.norm() < 1e-8 * (1.0 + w.norm())) {
      fit.converged = true;
      break;
    }
  }
  fit.weights.assign(w.data(), w.data() + w.size());
  return fit;
}

}  // namespace palletd
