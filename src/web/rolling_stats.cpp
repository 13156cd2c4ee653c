#include "rolling_stats.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace palletd::web {

void RollingWindow::add(double value) {
  if (!std::isfinite(value)) return;
  values_.push_back(value);
  while (values_.size() > capacity_) values_.pop_front();
}

std::optional<double> RollingWindow::percentile(double p) const {
  if (values_.empty()) return std::nullopt;
  std::vector<double> v(values_.begin(), values_.end());
  const double clamped = std::clamp(p, 0.0, 100.0);
  // Nearest rank: the smallest value with at least p % of the values at or below it.
  const auto n = static_cast<double>(v.size());
  auto rank = static_cast<std::size_t>(std::ceil(clamped / 100.0 * n));
  if (rank == 0) rank = 1;
  const auto k = static_cast<std::ptrdiff_t>(rank - 1);
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[static_cast<std::size_t>(k)];
}

std::optional<double> RollingWindow::max() const {
  if (values_.empty()) return std::nullopt;
  return *std::max_element(values_.begin(), values_.end());
}

}  // namespace palletd::web
