// Per-box and per-layout confidence: logistic models on the evidence (confidence.hpp). The
// weights were fitted offline by `palletd_fit_confidence` (tests/bench/confidence) on generated
// frames with ground truth; docs/benchmarks.md ("Confidence") has the command, the sets and the
// held-out check.
#include "palletd/detection/confidence.hpp"

#include <algorithm>
#include <cmath>

namespace palletd {

namespace {

// Fitted weights (bias first, the order of box_features / layout_features), printed by
//   palletd_fit_confidence fit --l2 1e-3 train_base.jsonl train_cell.jsonl train_over.jsonl
//       train2_base.jsonl train2_cell.jsonl train2_over.jsonl   (one command line)
// from `palletctl eval DIR --json` on six generated sets made for the fit (4912 boxes of 890
// layouts; docs/benchmarks.md, "Confidence", has the commands and the check on held-out sets).
constexpr std::array<double, kBoxFeatures> kBoxWeights = {
    6.13944,    0.273093, -0.0502455, 1.20002,  0.649625, -2.37203,   -0.408383, 0.446302,
    -0.0248756, 0.474499, -4.87804,   0.551759, 0.079594, -0.0391386, 1.10062};
constexpr std::array<double, kLayoutFeatures> kLayoutWeights = {1.36855, 0.203818, 0.714277, -1.201,
                                                                0.285784};

template <std::size_t N>
double dot(const std::array<double, N>& w, const std::array<double, N>& f) {
  double z = 0.0;
  for (std::size_t i = 0; i < N; ++i) z += w[i] * f[i];
  return z;
}

}  // namespace

double logistic(double z) { return 1.0 / (1.0 + std::exp(-std::clamp(z, -40.0, 40.0))); }

double log_odds(double p) {
  const double q = std::clamp(p, 1e-6, 1.0 - 1e-6);
  return std::log(q / (1.0 - q));
}

std::array<double, kBoxFeatures> box_features(const ScoreTerms& t) {
  // An unfitted box (the refinement rejected it or did not run) counts as placed to within the
  // refinement's anchor prior, 50 mm.
  const double sigma_mm = t.position_sigma_mm < 0.0 ? 50.0 : t.position_sigma_mm;
  const double contested = t.contested ? 1.0 : 0.0, ambiguous = t.layout_ambiguous ? 1.0 : 0.0;
  return {1.0,
          t.support,
          t.inside,
          t.edge_seams,
          t.interior_seam,
          std::log1p(sigma_mm),
          std::log1p(std::max(0.0, t.refine_shift_mm)),
          std::log(std::max(0.5, t.pitch_mm)),
          t.partly_unseen ? 1.0 : 0.0,
          contested,
          ambiguous,
          contested * ambiguous,
          t.outline_unobserved ? 1.0 : 0.0,
          std::clamp(t.rim_share, 0.0, 1.0),
          t.layout_formats > 1 ? 1.0 : 0.0};
}

double box_confidence(const ScoreTerms& terms) { return logistic(dot(kBoxWeights, box_features(terms))); }

std::array<double, kLayoutFeatures> layout_features(const std::vector<double>& box_scores, bool ambiguous,
                                                    bool outline_unobserved) {
  double sum_log = 0.0, min_odds = 40.0;
  for (const double p : box_scores) {
    sum_log += std::log(std::clamp(p, 1e-6, 1.0));
    min_odds = std::min(min_odds, log_odds(p));
  }
  return {1.0, sum_log, min_odds, ambiguous ? 1.0 : 0.0, outline_unobserved ? 1.0 : 0.0};
}

std::array<double, kLayoutFeatures> layout_features(const Detection& d) {
  std::vector<double> scores;
  scores.reserve(d.boxes.size());
  for (const DetectedBox& b : d.boxes) scores.push_back(b.score);
  return layout_features(scores, d.ambiguous, d.outline_unobserved);
}

double layout_confidence(const Detection& detection) {
  if (detection.boxes.empty()) return 0.0;
  return logistic(dot(kLayoutWeights, layout_features(detection)));
}

}  // namespace palletd
