// teach_from(), recipe_yaml(): carton sizes measured on a frame, as config entries.
#include "palletd/results/teach.hpp"

#include <algorithm>
#include <cmath>

#include "palletd/core/statistics.hpp"

namespace palletd {

namespace {

/// Boxes within this of a group's first box on both sides are one size [m].
constexpr double kSameSize_m = 0.015;

TaughtFormat summarize(const std::vector<const DetectedBox*>& group) {
  std::vector<double> longs, shorts;
  for (const DetectedBox* b : group) {
    longs.push_back(b->long_m);
    shorts.push_back(b->short_m);
  }
  const double l = upper_median(longs), s = upper_median(shorts);
  std::vector<double> deviation;
  for (double v : longs) deviation.push_back(std::abs(v - l));
  TaughtFormat f;
  f.long_mm = static_cast<int>(std::lround(1e3 * l));
  f.short_mm = static_cast<int>(std::lround(1e3 * s));
  f.spread_mm = 1e3 * upper_median(deviation);
  f.boxes = static_cast<int>(group.size());
  return f;
}

std::string format_name(const TaughtFormat& f) {
  return std::to_string(f.long_mm) + "x" + std::to_string(f.short_mm);
}

}  // namespace

Teaching teach_from(const Detection& detection) {
  Teaching t;
  if (detection.status != DetectionStatus::kOk || detection.boxes.empty()) {
    t.reason = std::string("no layout (") + to_string(detection.status) + "): " + detection.message;
    return t;
  }
  std::vector<std::vector<const DetectedBox*>> groups;
  for (const DetectedBox& b : detection.boxes) {
    auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& g) {
      return std::abs(g.front()->long_m - b.long_m) < kSameSize_m &&
             std::abs(g.front()->short_m - b.short_m) < kSameSize_m;
    });
    if (it == groups.end())
      groups.push_back({&b});
    else
      it->push_back(&b);
  }
  for (const auto& g : groups) t.formats.push_back(summarize(g));
  std::sort(t.formats.begin(), t.formats.end(),
            [](const TaughtFormat& a, const TaughtFormat& b) { return a.boxes > b.boxes; });
  t.taught = !detection.ambiguous;
  t.reason = detection.ambiguous ? "the frame does not settle the size: " + detection.ambiguity_reason : "";
  return t;
}

std::string recipe_yaml(const Teaching& teaching, int recipe_number, const std::string& recipe_name) {
  std::string formats = "formats:\n", names;
  for (const TaughtFormat& f : teaching.formats) {
    formats += "  - {name: \"" + format_name(f) + "\", long_mm: " + std::to_string(f.long_mm) +
               ", short_mm: " + std::to_string(f.short_mm) + "}\n";
    names += (names.empty() ? "\"" : ", \"") + format_name(f) + "\"";
  }
  return formats + "recipes:\n  - {number: " + std::to_string(recipe_number) + ", name: \"" + recipe_name +
         "\", formats: [" + names + "]}\n";
}

}  // namespace palletd
