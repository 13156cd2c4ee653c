// palletd detection: per-box and per-layout confidence. A logistic model on the evidence each box
// carries (ScoreTerms), fitted offline on generated frames with ground truth; the fitted weights
// live in confidence.cpp with the command that fitted them.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "palletd/detection/detection.hpp"

namespace palletd {

/// Inputs of the box model, in this order: 1 (bias), support, inside, edge_seams,
/// interior_seam, log(1 + position_sigma_mm), log(1 + refine_shift_mm), log(pitch_mm),
/// partly_unseen, contested, layout_ambiguous, contested x layout_ambiguous, outline_unobserved,
/// min(rim_share, 1), layout_formats > 1.
constexpr std::size_t kBoxFeatures = 15;
std::array<double, kBoxFeatures> box_features(const ScoreTerms& terms);

/// P(box right) = 1 / (1 + exp(-w . box_features(terms))) with the fitted weights.
double box_confidence(const ScoreTerms& terms);

/// Inputs of the layout model: 1 (bias), the sum over boxes of log(confidence), the smallest
/// box confidence's log-odds, ambiguous, outline_unobserved.
constexpr std::size_t kLayoutFeatures = 5;
/// From the boxes' confidences (`score`, already computed) and the detection's flags.
std::array<double, kLayoutFeatures> layout_features(const Detection& detection);
/// The same from the confidences and flags alone (for fitting).
std::array<double, kLayoutFeatures> layout_features(const std::vector<double>& box_scores, bool ambiguous,
                                                    bool outline_unobserved);

/// P(layout exact); 0 when the detection has no boxes.
double layout_confidence(const Detection& detection);

/// Logistic function and its inverse, clamped away from 0 and 1.
double logistic(double z);
double log_odds(double p);

}  // namespace palletd
