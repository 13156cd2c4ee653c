// palletd io: how well scores separate right from wrong and whether they mean what they say
// (discrimination, reliability), and the logistic fit that calibrates them (for `palletctl eval`
// and tests/bench/confidence).
#pragma once

#include <cstddef>
#include <vector>

#include "palletd/results/evaluation.hpp"

namespace palletd {

/// Probability that a right item outscores a wrong one (ties count half): the area under the ROC
/// curve. 0 when either class is missing.
double roc_auc(const std::vector<double>& scores, const std::vector<bool>& right);

/// Scores in [lo, hi) (the last bin includes 1) and the share of them that are right.
struct ReliabilityBin {
  double lo = 0.0, hi = 0.0;
  std::size_t n = 0;
  double mean_score = 0.0;
  double right_share = 0.0;
};
/// `bins` bins of equal width over 0..1.
std::vector<ReliabilityBin> reliability_bins(const std::vector<double>& scores,
                                             const std::vector<bool>& right, int bins = 10);

/// `groups` groups of (nearly) equal count in score order: the deciles of the score (lo, hi
/// are the lowest and highest score in each).
std::vector<ReliabilityBin> score_deciles(const std::vector<double>& scores, const std::vector<bool>& right,
                                          int groups = 10);

/// Discrimination and calibration of one kind of score over a set.
struct ScoreReport {
  std::size_t items = 0, right = 0;
  double auc = 0.0;
  std::vector<ReliabilityBin> bins;
  /// Largest |right_share - mean_score| over bins holding at least min_bin items.
  double max_bin_gap = 0.0;
  std::vector<ReliabilityBin> deciles;   ///< score_deciles()
  double max_decile_gap = 0.0;           ///< largest |right_share - mean_score| over the deciles
  std::size_t high = 0, high_right = 0;  ///< items scored >= 0.9 and how many of them are right
};
ScoreReport score_report(const std::vector<double>& scores, const std::vector<bool>& right,
                         std::size_t min_bin = 30);

/// Boxes (score, right) and layouts (layout_confidence, exact) over a set's frames. A layout
/// counts when the detection reported boxes.
struct ConfidenceReport {
  ScoreReport boxes;
  ScoreReport layouts;
};
ConfidenceReport confidence_report(const std::vector<FrameEval>& frames, std::size_t min_bin = 30);

/// Logistic regression by iteratively reweighted least squares with an L2 penalty `l2` on every
/// weight but the first (x[i][0] is the bias input 1). Weights in the order of x's columns.
struct LogisticFit {
  std::vector<double> weights;
  int iterations = 0;
  bool converged = false;
};
LogisticFit fit_logistic(const std::vector<std::vector<double>>& x, const std::vector<bool>& y,
                         double l2 = 1e-3);

}  // namespace palletd
