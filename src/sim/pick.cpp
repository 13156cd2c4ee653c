// What a pick does to the layer (pick.hpp): rigid cartons that do not pass through each other.
#include "palletd/sim/pick.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "sim_internal.hpp"

namespace palletd::sim {

namespace {

/// A taken box is lowered this far: out of the layer, out of the camera's band.
constexpr double kTakenTop_m = -1.0;
/// Boxes count as overlapping when they cut into each other by more than this.
constexpr double kOverlapTolerance_m = 1e-4;
constexpr double kDragMin_m = 0.005, kDragMax_m = 0.040;
constexpr double kTurnMin_deg = 2.0, kTurnMax_deg = 5.0, kTurnStep_deg = 0.5;

bool inside_footprint(const SimBox& b, const Eigen::Vector2d& p) {
  const Eigen::Vector2d q = Eigen::Rotation2Dd(-b.yaw_rad) * (p - b.center);
  return std::abs(q.x()) <= 0.5 * b.long_m && std::abs(q.y()) <= 0.5 * b.short_m;
}

/// A side of a footprint: its middle, outward normal, direction along it and half length.
struct BoxSide {
  Eigen::Vector2d middle, normal, along;
  double half_m = 0.0;
};

BoxSide box_side(const SimBox& b, int k) {
  const Eigen::Vector2d u(std::cos(b.yaw_rad), std::sin(b.yaw_rad)), v(-u.y(), u.x());
  const double sign = k % 2 == 0 ? 1.0 : -1.0;
  if (k < 2) return {b.center + sign * 0.5 * b.long_m * u, sign * u, v, 0.5 * b.short_m};
  return {b.center + sign * 0.5 * b.short_m * v, sign * v, u, 0.5 * b.long_m};
}

/// Length of `side` that `other` stands beside, at most a wide gap (20 mm) away [m].
double contact_m(const BoxSide& side, const SimBox& other) {
  constexpr double kStep_m = 0.01;
  double length_m = 0.0;
  for (double a = -side.half_m + 0.5 * kStep_m; a < side.half_m; a += kStep_m)
    for (const double out_m : {0.004, 0.012, 0.020})
      if (inside_footprint(other, side.middle + a * side.along + out_m * side.normal)) {
        length_m += kStep_m;
        break;
      }
  return length_m;
}

bool fits(const Scene& scene, const SimBox& moved, std::size_t self) {
  for (const std::size_t j : scene.top_layer)
    if (j != self && !taken_off(scene.boxes[j]) &&
        detail::footprints_overlap(moved, scene.boxes[j], kOverlapTolerance_m))
      return false;
  return true;
}

/// The standing top-layer box sharing the longest stretch of side with `picked` (at least
/// 5 cm), and the direction from it toward the picked box.
std::optional<std::pair<std::size_t, Eigen::Vector2d>> side_neighbour(const Scene& scene,
                                                                      std::size_t picked) {
  std::optional<std::pair<std::size_t, Eigen::Vector2d>> best;
  double best_m = 0.05;
  for (int k = 0; k < 4; ++k) {
    const BoxSide side = box_side(scene.boxes[picked], k);
    for (const std::size_t j : scene.top_layer) {
      if (j == picked || taken_off(scene.boxes[j])) continue;
      if (const double c = contact_m(side, scene.boxes[j]); c > best_m) {
        best_m = c;
        best = std::make_pair(j, Eigen::Vector2d(-side.normal));
      }
    }
  }
  return best;
}

/// Drags box `j` up to `amount_m` along `toward`, halving the distance until it fits.
std::optional<SimBox> drag(const Scene& scene, std::size_t j, const Eigen::Vector2d& toward,
                           double amount_m) {
  for (; amount_m >= kDragMin_m; amount_m *= 0.5) {
    SimBox moved = scene.boxes[j];
    moved.center += amount_m * toward;
    if (fits(scene, moved, j)) return moved;
  }
  return std::nullopt;
}

/// Turns box `j` by up to `turn_rad` about one end of its side facing `toward` (the other end
/// swings toward the gap), moved up to the longest drag further toward it, whichever fits first.
std::optional<SimBox> turn(const Scene& scene, std::size_t j, const Eigen::Vector2d& toward, double turn_rad,
                           bool first_end) {
  const SimBox& box = scene.boxes[j];
  int facing = 0;
  for (int k = 1; k < 4; ++k)
    if (box_side(box, k).normal.dot(toward) > box_side(box, facing).normal.dot(toward)) facing = k;
  const BoxSide side = box_side(box, facing);
  for (double angle = turn_rad; angle >= kTurnMin_deg * M_PI / 180.0 - 1e-9;
       angle -= kTurnStep_deg * M_PI / 180.0)
    for (const double end : {first_end ? 1.0 : -1.0, first_end ? -1.0 : 1.0}) {
      const Eigen::Vector2d pivot = side.middle + end * side.half_m * side.along;
      const Eigen::Vector2d swung = side.middle - end * side.half_m * side.along - pivot;
      const double sign = Eigen::Vector2d(-swung.y(), swung.x()).dot(toward) > 0.0 ? 1.0 : -1.0;
      SimBox moved = box;
      moved.center = pivot + Eigen::Rotation2Dd(sign * angle) * (box.center - pivot);
      moved.yaw_rad += sign * angle;
      const Eigen::Vector2d turned_center = moved.center;
      for (double d_m = 0.0; d_m <= kDragMax_m + 1e-9; d_m += 0.001) {
        moved.center = turned_center + d_m * toward;
        if (fits(scene, moved, j)) return moved;
      }
    }
  return std::nullopt;
}

}  // namespace

PickOutcome simulate_pick(Scene& scene, std::size_t picked, PickEvent event, std::uint64_t seed) {
  detail::Rng rng(seed, 0x9C);
  PickOutcome out;
  if (event == PickEvent::kMissed) {
    out.event = event;
    return out;
  }
  take_off(scene.boxes[picked]);
  out.gone.push_back(picked);
  const auto neighbour = side_neighbour(scene, picked);
  if (event == PickEvent::kClean || !neighbour) return out;
  const auto [j, toward] = *neighbour;
  out.neighbour = j;
  if (event == PickEvent::kDouble) {
    take_off(scene.boxes[j]);
    out.gone.push_back(j);
    out.event = event;
    return out;
  }
  std::optional<SimBox> moved;
  if (event == PickEvent::kTurn) {
    const double turn_rad = rng.uniform(kTurnMin_deg, kTurnMax_deg) * M_PI / 180.0;
    moved = turn(scene, j, toward, turn_rad, rng.chance(0.5));
    if (moved) out.event = PickEvent::kTurn;
  }
  if (!moved) {
    moved = drag(scene, j, toward, rng.uniform(kDragMin_m, kDragMax_m));
    if (moved) out.event = PickEvent::kDrag;
  }
  if (!moved) {
    out.neighbour.reset();
    return out;
  }
  out.shift_m = moved->center - scene.boxes[j].center;
  out.turn_rad = moved->yaw_rad - scene.boxes[j].yaw_rad;
  scene.boxes[j] = *moved;
  return out;
}

void take_off(SimBox& box) {
  box.top_z_m = kTakenTop_m;
  box.bottom_z_m = kTakenTop_m - 0.3;
}

bool taken_off(const SimBox& box) { return box.top_z_m < kTakenTop_m + 0.1; }

const char* to_string(PickEvent event) {
  switch (event) {
    case PickEvent::kClean:
      return "clean";
    case PickEvent::kMissed:
      return "missed";
    case PickEvent::kDouble:
      return "double";
    case PickEvent::kDrag:
      return "drag";
    case PickEvent::kTurn:
      return "turn";
  }
  return "clean";
}

}  // namespace palletd::sim
