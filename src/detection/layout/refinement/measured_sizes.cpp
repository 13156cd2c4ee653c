// Box side lengths measured from the side observations alone (see measured_sizes.hpp).
#include "refinement/measured_sizes.hpp"

#include <cmath>
#include <optional>

namespace palletd::layout_detail {

namespace {

/// Longest run followed: a row longer than a pallet is no row.
constexpr int kMaxRun = 12;

/// The position of side (axis, sign) of box k, when it was measured.
std::optional<double> side_at(const std::vector<SideObservation>& sides, std::size_t k, int axis, int sign) {
  for (const SideObservation& s : sides) {
    if (static_cast<std::size_t>(s.box) == k && s.axis == axis && s.sign == sign) return s.pos_m;
  }
  return std::nullopt;
}

/// The one box pressed against side (axis, sign) of box k; -1 for none or several.
int pressed_neighbour(const std::vector<Contact>& contacts, std::size_t k, int axis, int sign) {
  int found = -1;
  for (const Contact& c : contacts) {
    if (c.axis != axis) continue;
    const int from = sign > 0 ? c.a : c.b, to = sign > 0 ? c.b : c.a;
    if (static_cast<std::size_t>(from) != k) continue;
    if (found >= 0) return -1;
    found = to;
  }
  return found;
}

/// Walks from box k toward `sign` through pressed neighbours of k's nominal size until a box
/// whose side that way was measured; returns that side's position and counts the boxes passed.
std::optional<double> run_end(const std::vector<SideObservation>& sides, const std::vector<Contact>& contacts,
                              const std::vector<JointBox>& boxes, std::size_t k, int axis, int sign, int* count) {
  std::size_t at = k;
  for (int step = 0; step < kMaxRun; ++step) {
    if (const std::optional<double> end = side_at(sides, at, axis, sign)) return end;
    const int next = pressed_neighbour(contacts, at, axis, sign);
    if (next < 0) return std::nullopt;
    const auto n = static_cast<std::size_t>(next);
    if (pressed_neighbour(contacts, n, axis, -sign) != static_cast<int>(at)) return std::nullopt;  // a branch
    if (std::abs(boxes[n].half_nominal[axis] - boxes[k].half_nominal[axis]) > 1e-6) return std::nullopt;
    at = n;
    ++*count;
  }
  return std::nullopt;
}

}  // namespace

Eigen::Vector2d measured_extent(const std::vector<SideObservation>& sides, std::size_t k) {
  Eigen::Vector2d out(-1.0, -1.0);
  for (int a = 0; a < 2; ++a) {
    const std::optional<double> lo = side_at(sides, k, a, -1), hi = side_at(sides, k, a, 1);
    if (lo && hi && *hi > *lo) out[a] = *hi - *lo;
  }
  return out;
}

Eigen::Vector2d run_extent(const std::vector<SideObservation>& sides, const std::vector<Contact>& contacts,
                           const std::vector<JointBox>& boxes, std::size_t k) {
  Eigen::Vector2d out(-1.0, -1.0);
  for (int a = 0; a < 2; ++a) {
    int count = 1;
    const std::optional<double> lo = run_end(sides, contacts, boxes, k, a, -1, &count);
    if (!lo) continue;
    const std::optional<double> hi = run_end(sides, contacts, boxes, k, a, 1, &count);
    if (hi && *hi > *lo && count > 1) out[a] = (*hi - *lo) / count;
  }
  return out;
}

}  // namespace palletd::layout_detail
