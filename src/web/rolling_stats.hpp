// palletd web: a rolling window of recent values with percentiles (processing time, latency).
// Not thread-safe; the server guards it with its own mutex.
#pragma once

#include <cstddef>
#include <deque>
#include <optional>

namespace palletd::web {

class RollingWindow {
 public:
  explicit RollingWindow(std::size_t capacity) : capacity_(capacity == 0 ? 1 : capacity) {}

  /// Adds a value; the oldest one drops out beyond the capacity. Non-finite values are ignored.
  void add(double value);
  [[nodiscard]] std::size_t size() const { return values_.size(); }
  /// Nearest-rank percentile, p in [0, 100]; nothing when the window is empty.
  [[nodiscard]] std::optional<double> percentile(double p) const;
  [[nodiscard]] std::optional<double> max() const;

 private:
  std::size_t capacity_;
  std::deque<double> values_;
};

}  // namespace palletd::web
