// palletd core: order statistics that detection and results share.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace palletd {

/// The upper median of `values` (the element at index n / 2 once sorted); `if_empty` for none.
inline double upper_median(std::vector<double> values, double if_empty = 0.0) {
  if (values.empty()) return if_empty;
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace palletd
