#include "palletd/results/comparison.hpp"

#include <algorithm>
#include <cstdio>

namespace palletd {

DetectionDifference compare_detections(const Detection& a, const Detection& b, double moved_mm) {
  DetectionDifference d;
  d.status_differs = a.status != b.status;
  d.count_differs = a.boxes.size() != b.boxes.size();
  d.ambiguous_differs = a.ambiguous != b.ambiguous;
  // Greedy pairing on the closest centres of all pairs: a layout shifted by one box pairs each box
  // with its neighbour, which then shows as moved.
  struct Pair {
    double distance_mm;
    std::size_t i, j;
  };
  std::vector<Pair> pairs;
  for (std::size_t i = 0; i < a.boxes.size(); ++i)
    for (std::size_t j = 0; j < b.boxes.size(); ++j)
      pairs.push_back({(a.boxes[i].center - b.boxes[j].center).norm() * 1000.0, i, j});
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& p, const Pair& q) { return p.distance_mm < q.distance_mm; });
  std::vector<bool> used_a(a.boxes.size(), false), used_b(b.boxes.size(), false);
  for (const Pair& p : pairs) {
    if (used_a[p.i] || used_b[p.j]) continue;
    used_a[p.i] = used_b[p.j] = true;
    d.max_move_mm = std::max(d.max_move_mm, p.distance_mm);
    if (p.distance_mm > moved_mm) ++d.boxes_moved;
    if (a.boxes[p.i].format != b.boxes[p.j].format) d.format_differs = true;
  }
  return d;
}

std::string DetectionDifference::describe(const Detection& a, const Detection& b) const {
  std::string out;
  const auto add = [&out](const std::string& part) { out += (out.empty() ? "" : "; ") + part; };
  if (status_differs) add(std::string("status ") + to_string(a.status) + " -> " + to_string(b.status));
  if (count_differs) add("boxes " + std::to_string(a.boxes.size()) + " -> " + std::to_string(b.boxes.size()));
  if (boxes_moved > 0) {
    char text[96];
    std::snprintf(text, sizeof text, "%d box(es) moved (max %.1f mm)", boxes_moved, max_move_mm);
    add(text);
  }
  if (format_differs) add("formats differ");
  if (ambiguous_differs)
    add(std::string("ambiguous ") + (a.ambiguous ? "yes" : "no") + " -> " + (b.ambiguous ? "yes" : "no"));
  return out.empty() ? "same" : out;
}

}  // namespace palletd
