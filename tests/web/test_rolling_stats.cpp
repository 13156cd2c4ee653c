#include <catch2/catch.hpp>

#include <cmath>

#include "rolling_stats.hpp"

using palletd::web::RollingWindow;

TEST_CASE("rolling window: nearest-rank percentiles over the newest values") {
  RollingWindow w(10);
  CHECK_FALSE(w.percentile(50.0).has_value());
  for (int i = 10; i >= 1; --i) w.add(i);  // unsorted input
  CHECK(w.size() == 10);
  CHECK(*w.percentile(50.0) == 5.0);
  CHECK(*w.percentile(99.0) == 10.0);
  CHECK(*w.percentile(0.0) == 1.0);
  CHECK(*w.percentile(10.0) == 1.0);
  CHECK(*w.percentile(11.0) == 2.0);
  w.add(std::nan(""));  // ignored
  CHECK(w.size() == 10);
  for (int i = 0; i < 5; ++i) w.add(100.0);  // pushes out 10, 9, 8, 7, 6
  CHECK(w.size() == 10);
  CHECK(*w.percentile(50.0) == 5.0);
  CHECK(*w.percentile(60.0) == 100.0);
  CHECK(*w.max() == 100.0);
}
