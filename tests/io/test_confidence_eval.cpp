// Discrimination, reliability and the logistic fit behind the calibrated confidence
// (results/confidence_eval.hpp).
#include <cmath>
#include <random>

#include <catch2/catch.hpp>

#include "palletd/results/confidence_eval.hpp"

using namespace palletd;

TEST_CASE("AUC is the chance that a right item outscores a wrong one", "[confidence]") {
  // Right items 0.35 and 0.8, wrong 0.1 and 0.4: 3 of the 4 pairs ordered right.
  CHECK(roc_auc({0.1, 0.4, 0.35, 0.8}, {false, false, true, true}) == Approx(0.75));
  CHECK(roc_auc({0.2, 0.9}, {false, true}) == Approx(1.0));
  CHECK(roc_auc({0.9, 0.2}, {false, true}) == Approx(0.0));
  CHECK(roc_auc({0.5, 0.5, 0.5}, {false, true, true}) == Approx(0.5));  // ties count half
  CHECK(roc_auc({0.5, 0.7}, {true, true}) == 0.0);                      // no wrong item
}

TEST_CASE("reliability bins and the report", "[confidence]") {
  const std::vector<double> scores = {0.05, 0.95, 0.92, 1.0, 0.55};
  const std::vector<bool> right = {false, true, false, true, true};
  const std::vector<ReliabilityBin> bins = reliability_bins(scores, right);
  REQUIRE(bins.size() == 10);
  CHECK(bins[0].n == 1);
  CHECK(bins[0].right_share == 0.0);
  CHECK(bins[5].n == 1);
  CHECK(bins[9].n == 3);  // 1.0 falls in the last bin
  CHECK(bins[9].mean_score == Approx((0.95 + 0.92 + 1.0) / 3));
  CHECK(bins[9].right_share == Approx(2.0 / 3));
  const ScoreReport r = score_report(scores, right, 1);
  CHECK(r.items == 5);
  CHECK(r.right == 3);
  CHECK(r.high == 3);
  CHECK(r.high_right == 2);
  CHECK(r.max_bin_gap == Approx(0.45));  // bin 5: mean 0.55, all right; bin 9: 0.29; bin 0: 0.05
}

TEST_CASE("the logistic fit recovers the weights that generated the labels", "[confidence]") {
  std::mt19937 rng(7);
  std::normal_distribution<double> feature(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double w0 = 1.5, w1 = -2.0, w2 = 0.7;
  std::vector<std::vector<double>> x;
  std::vector<bool> y;
  for (int i = 0; i < 20000; ++i) {
    const double a = feature(rng), b = feature(rng);
    x.push_back({1.0, a, b});
    y.push_back(u(rng) < 1.0 / (1.0 + std::exp(-(w0 + w1 * a + w2 * b))));
  }
  const LogisticFit fit = fit_logistic(x, y, 0.0);
  REQUIRE(fit.converged);
  REQUIRE(fit.weights.size() == 3);
  CHECK(fit.weights[0] == Approx(w0).margin(0.1));
  CHECK(fit.weights[1] == Approx(w1).margin(0.1));
  CHECK(fit.weights[2] == Approx(w2).margin(0.1));
  // A strong penalty pulls the slopes toward zero, never the bias.
  const LogisticFit shrunk = fit_logistic(x, y, 1.0);
  CHECK(std::abs(shrunk.weights[1]) < 0.5 * std::abs(fit.weights[1]));
}
