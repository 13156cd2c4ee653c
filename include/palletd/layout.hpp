// palletd detection, second half (paper Section IV): box layout search, seam evidence,
// refinement. Values in, values out.
#pragma once

#include <string>
#include <vector>

#include "palletd/geometry.hpp"
#include "palletd/layer.hpp"

namespace palletd {

enum class SearchMode { product, paper };

struct LayoutParams {
  SearchMode search = SearchMode::product;
  double a_min_fraction = 0.9;   ///< a box is on the layer when Area(B ∩ C) > a_min_fraction * Area(B)
  double a_max_fraction = 0.1;   ///< and overlaps the hypothesis by less than a_max_fraction * Area(B)
  double time_budget_ms = 50.0;  ///< search budget per frame [ms]; the best so far is returned past it
  double ambiguity_margin = 0.01;  ///< relative score gap under which two layouts count as tied
};

/// Result of the layout search for all components of a layer.
struct LayoutResult {
  DetectionStatus status = DetectionStatus::no_layout;
  std::string reason;
  std::vector<Box2d> boxes;          ///< layer frame
  std::vector<double> box_scores;    ///< 0..1 per box
  bool ambiguous = false;
  bool budget_exhausted = false;
  double coverage = 0.0;             ///< covered share of the layer area
  std::size_t hypotheses_visited = 0;
};

}  // namespace palletd
