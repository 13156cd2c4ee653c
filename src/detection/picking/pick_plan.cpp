// plan_picks(): rows a wide gripper can take together, the order that keeps the rest pickable,
// and what can be picked now.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "pick_internal.hpp"

namespace palletd {
namespace picking {

namespace {

/// Boxes in a row stand this far off the row's line at most, and turn this much at most.
constexpr double kRowOffset_m = 0.015;
constexpr double kRowTurn_rad = 3.0 * M_PI / 180.0;
/// Two boxes whose sides overlap by this much are still neighbours in a row (measured sides).
constexpr double kRowOverlap_m = 0.005;
/// A row's union may exceed the footprint by this much and still count as under it.
constexpr double kFitTolerance_m = 0.010;

/// The box next to `from` along `direction` (a unit vector along one of its axes), same format
/// and turn, within the gap limit; -1 when none stands there.
int next_in_row(int from, const Eigen::Vector2d& direction, double pitch_m,
                const std::vector<DetectedBox>& boxes, const std::vector<char>& standing, double max_gap_m) {
  const Box2d& a = boxes[static_cast<std::size_t>(from)].in_layer;
  for (std::size_t j = 0; j < boxes.size(); ++j) {
    const Box2d& b = boxes[j].in_layer;
    if (static_cast<int>(j) == from || standing[j] == 0 || b.format != a.format) continue;
    const double turn = std::abs(std::remainder(b.yaw_rad - a.yaw_rad, M_PI));
    if (turn > kRowTurn_rad) continue;
    const Eigen::Vector2d d = b.center - a.center;
    const double along = d.dot(direction);
    const double across = std::abs(d.x() * direction.y() - d.y() * direction.x());
    const double gap = along - pitch_m;
    if (across <= kRowOffset_m && gap >= -kRowOverlap_m && gap <= max_gap_m) return static_cast<int>(j);
  }
  return -1;
}

/// The row through `seed` along its long (axis 0) or short (axis 1) side: up to `reach` boxes
/// each way, in order along the row.
std::vector<int> row_through(int seed, int axis, int reach, const std::vector<DetectedBox>& boxes,
                             const std::vector<char>& standing, double max_gap_m) {
  const Box2d& s = boxes[static_cast<std::size_t>(seed)].in_layer;
  const Eigen::Vector2d u(std::cos(s.yaw_rad), std::sin(s.yaw_rad));
  const Eigen::Vector2d direction = axis == 0 ? u : Eigen::Vector2d(-u.y(), u.x());
  const double pitch_m = axis == 0 ? s.long_m : s.short_m;
  std::vector<int> row{seed};
  for (const double sign : {1.0, -1.0}) {
    int at = seed;
    for (int k = 0; k < reach; ++k) {
      at = next_in_row(at, sign * direction, pitch_m, boxes, standing, max_gap_m);
      if (at < 0 || std::find(row.begin(), row.end(), at) != row.end()) break;
      if (sign > 0)
        row.push_back(at);
      else
        row.insert(row.begin(), at);
    }
  }
  return row;
}

/// The footprint over boxes row[first .. first+count), or nullopt when they do not fit under it.
std::optional<Rect> row_footprint(const std::vector<int>& row, std::size_t first, std::size_t count, int axis,
                                  const std::vector<DetectedBox>& boxes, const GripperParams& gripper) {
  const Box2d& a = boxes[static_cast<std::size_t>(row[first])].in_layer;
  const Box2d& b = boxes[static_cast<std::size_t>(row[first + count - 1])].in_layer;
  // The row's own direction (first to last centre), not one box's yaw: a box turned by a degree
  // would swing the footprint's far end into the next row.
  const Eigen::Vector2d u_a(std::cos(a.yaw_rad), std::sin(a.yaw_rad));
  const Eigen::Vector2d along = (b.center - a.center).normalized();
  Eigen::Vector2d u = axis == 0 ? along : Eigen::Vector2d(along.y(), -along.x());
  if (u.dot(u_a) < 0.0) u = -u;
  const Eigen::Vector2d v(-u.y(), u.x());
  const Eigen::Vector2d direction = axis == 0 ? u : v;
  const double span_along_m =
      std::abs((b.center - a.center).dot(direction)) + (axis == 0 ? a.long_m : a.short_m);
  const double span_across_m = axis == 0 ? a.short_m : a.long_m;
  // The union's extent along the box's long side (u) and short side (v).
  const double union_u_m = axis == 0 ? span_along_m : span_across_m;
  const double union_v_m = axis == 0 ? span_across_m : span_along_m;
  const double long_m = 1e-3 * gripper.footprint_mm.x(), short_m = 1e-3 * gripper.footprint_mm.y();
  Rect footprint;
  footprint.center = 0.5 * (a.center + b.center);
  footprint.half_long_m = 0.5 * long_m;
  footprint.half_short_m = 0.5 * short_m;
  // The footprint's long side along the box's long side where the row fits so, else turned.
  if (union_u_m <= long_m + kFitTolerance_m && union_v_m <= short_m + kFitTolerance_m)
    footprint.axis = u;
  else if (union_v_m <= long_m + kFitTolerance_m && union_u_m <= short_m + kFitTolerance_m)
    footprint.axis = v;
  else
    return std::nullopt;
  return footprint;
}

/// Where the footprint may go over `area` (a box or a row): centred, then, where the footprint is
/// larger, flush with one or two of the area's sides so that it overhangs the others (the
/// outside of the layer, a gap, a box already picked).
std::vector<Rect> placements(const Rect& footprint, const Rect& area) {
  std::vector<Rect> out{footprint};
  const Eigen::Vector2d u = footprint.axis, v(-u.y(), u.x());
  // Slack of the footprint over the area along u and v (the area's extents measured along them).
  const double slack_u = footprint.half_long_m - (area.half_long_m * std::abs(area.axis.dot(u)) +
                                                  area.half_short_m * std::abs(area.axis.dot(v)));
  const double slack_v = footprint.half_short_m - (area.half_long_m * std::abs(area.axis.dot(v)) +
                                                   area.half_short_m * std::abs(area.axis.dot(u)));
  const double du = std::max(0.0, slack_u), dv = std::max(0.0, slack_v);
  for (const double su : {0.0, 1.0, -1.0}) {
    for (const double sv : {0.0, 1.0, -1.0}) {
      if ((su == 0.0 && sv == 0.0) || (su != 0.0 && du == 0.0) || (sv != 0.0 && dv == 0.0)) continue;
      Rect r = footprint;
      r.center += su * du * u + sv * dv * v;
      out.push_back(r);
    }
  }
  return out;
}

/// The area a set of boxes covers: a row's union, as a rectangle along the row's direction.
Rect area_of(const std::vector<int>& row, std::size_t first, std::size_t count, int axis,
             const std::vector<DetectedBox>& boxes) {
  const Box2d& a = boxes[static_cast<std::size_t>(row[first])].in_layer;
  const Box2d& b = boxes[static_cast<std::size_t>(row[first + count - 1])].in_layer;
  Rect area = rect_of(a);
  const Eigen::Vector2d along = (b.center - a.center).normalized();
  area.axis = axis == 0 ? along : Eigen::Vector2d(along.y(), -along.x());
  area.center = 0.5 * (a.center + b.center);
  const Eigen::Vector2d direction = axis == 0 ? area.axis : Eigen::Vector2d(-area.axis.y(), area.axis.x());
  const double span_m = std::abs((b.center - a.center).dot(direction));
  (axis == 0 ? area.half_long_m : area.half_short_m) += 0.5 * span_m;
  return area;
}

}  // namespace

Pick single_pick(int index, const std::vector<DetectedBox>& boxes, const GripperParams& gripper) {
  const Box2d& b = boxes[static_cast<std::size_t>(index)].in_layer;
  Pick pick;
  pick.boxes = {index};
  pick.area = rect_of(b);
  pick.centred.center = b.center;
  pick.centred.axis = pick.area.axis;
  pick.centred.half_long_m = 0.5e-3 * gripper.footprint_mm.x();
  pick.centred.half_short_m = 0.5e-3 * gripper.footprint_mm.y();
  pick.footprint = pick.centred;
  return pick;
}

std::optional<Pick> placed(Pick pick, const std::vector<char>& standing, PlacementCheck& check) {
  for (const Rect& place : placements(pick.centred, pick.area)) {
    pick.footprint = place;
    if (check.lasting_block(pick) == PickBlock::kNone && !check.covers_neighbour(pick, standing)) return pick;
  }
  return std::nullopt;
}

std::optional<Pick> best_pick(int seed, const std::vector<DetectedBox>& boxes,
                              const std::vector<char>& standing, PlacementCheck& check) {
  const GripperParams& gripper = check.gripper();
  if (gripper.max_boxes > 1) {
    const int reach = gripper.max_boxes - 1;
    const std::vector<int> rows[2] = {
        row_through(seed, 0, reach, boxes, standing, 1e-3 * gripper.max_group_gap_mm),
        row_through(seed, 1, reach, boxes, standing, 1e-3 * gripper.max_group_gap_mm)};
    for (std::size_t count = static_cast<std::size_t>(gripper.max_boxes); count >= 2; --count) {
      for (int axis = 0; axis < 2; ++axis) {
        const std::vector<int>& row = rows[axis];
        if (row.size() < count) continue;
        const auto at = static_cast<std::size_t>(std::find(row.begin(), row.end(), seed) - row.begin());
        // Windows holding the seed, the one that starts at it first.
        for (std::size_t first = std::min(at, row.size() - count) + 1; first-- > 0;) {
          if (first + count <= at) break;
          const std::optional<Rect> footprint = row_footprint(row, first, count, axis, boxes, gripper);
          if (!footprint) continue;
          Pick pick;
          pick.boxes.assign(row.begin() + static_cast<std::ptrdiff_t>(first),
                            row.begin() + static_cast<std::ptrdiff_t>(first + count));
          std::sort(pick.boxes.begin(), pick.boxes.end());
          pick.centred = pick.footprint = *footprint;
          pick.area = area_of(row, first, count, axis, boxes);
          if (std::optional<Pick> clear = placed(std::move(pick), standing, check)) return clear;
        }
      }
    }
  }
  return alone_pick(seed, boxes, standing, check).clear;
}

AloneVerdict alone_pick(int index, const std::vector<DetectedBox>& boxes, const std::vector<char>& standing,
                        PlacementCheck& check) {
  AloneVerdict verdict;
  Pick alone = single_pick(index, boxes, check.gripper());
  verdict.footprint = alone.footprint;
  verdict.block = check.lasting_block(alone);
  for (const Rect& place : placements(alone.centred, alone.area)) {
    alone.footprint = place;
    if (check.lasting_block(alone) != PickBlock::kNone) continue;
    if (verdict.block !=
        PickBlock::kNone) {  // a placement free of lasting blocks: the neighbours are what is left
      verdict.block = PickBlock::kNeighbour;
      verdict.footprint = place;
    }
    if (check.covers_neighbour(alone, standing)) continue;
    verdict.block = PickBlock::kNone;
    verdict.footprint = place;
    verdict.clear = alone;
    return verdict;
  }
  if (verdict.block == PickBlock::kNone) verdict.block = PickBlock::kNeighbour;
  return verdict;
}

}  // namespace picking

namespace {

using picking::Pick;

/// The picks one after another as the robot would make them (see plan_picks()).
std::vector<Pick> pick_sequence(const std::vector<DetectedBox>& boxes, picking::PlacementCheck& check) {
  std::vector<Pick> sequence;
  std::vector<char> standing(boxes.size(), 1);
  for (bool progress = true; progress;) {
    progress = false;
    for (std::size_t s = 0; s < boxes.size() && !progress; ++s) {
      if (standing[s] == 0) continue;
      if (std::optional<Pick> pick = picking::best_pick(static_cast<int>(s), boxes, standing, check)) {
        for (const int i : pick->boxes) standing[static_cast<std::size_t>(i)] = 0;
        sequence.push_back(std::move(*pick));
        progress = true;
      }
    }
  }
  return sequence;
}

}  // namespace

std::vector<PickGroup> plan_picks(const PickSurroundings& surroundings, const GripperParams& gripper,
                                  std::vector<DetectedBox>& boxes) {
  picking::PlacementCheck check(surroundings, gripper, boxes);
  const std::vector<Pick> sequence = pick_sequence(boxes, check);
  const std::vector<char> all_standing(boxes.size(), 1);

  // What can be picked now: the sequence's picks that need nothing else gone first, then boxes
  // that can be taken alone now although the sequence took them with a row later.
  std::vector<Pick> now;
  std::vector<char> in_group(boxes.size(), 0);
  for (const Pick& pick : sequence) {
    // The same boxes, placed again with everything standing (the sequence may have placed the
    // footprint over a box it had taken before).
    std::optional<Pick> clear = picking::placed(pick, all_standing, check);
    if (!clear) continue;
    for (const int i : clear->boxes) in_group[static_cast<std::size_t>(i)] = 1;
    now.push_back(std::move(*clear));
  }
  // Every box: pickable now or why not, and the TCP to take it alone.
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const picking::AloneVerdict alone = picking::alone_pick(static_cast<int>(i), boxes, all_standing, check);
    if (in_group[i] == 0 && alone.clear) {
      in_group[i] = 1;
      now.push_back(*alone.clear);
    }
    BoxPick pick;
    pick.tcp = check.tcp(alone.footprint);
    pick.pickable = in_group[i] != 0;
    if (!pick.pickable) pick.blocked_by = alone.block;
    boxes[i].pick = pick;
  }

  // The new pick order: what can be picked now, then the rest of the sequence, then the boxes it
  // could not take; each in the sequence's order, which follows the configured one.
  std::vector<int> position(boxes.size(), static_cast<int>(boxes.size()));
  int k = 0;
  for (const Pick& pick : sequence)
    for (const int i : pick.boxes) position[static_cast<std::size_t>(i)] = k++;
  std::sort(now.begin(), now.end(), [&](const Pick& a, const Pick& b) {
    return position[static_cast<std::size_t>(a.boxes.front())] <
           position[static_cast<std::size_t>(b.boxes.front())];
  });
  std::vector<int> order;
  for (const Pick& pick : now) order.insert(order.end(), pick.boxes.begin(), pick.boxes.end());
  std::vector<int> rest;
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (in_group[i] == 0) rest.push_back(static_cast<int>(i));
  std::stable_sort(rest.begin(), rest.end(), [&](int a, int b) {
    return position[static_cast<std::size_t>(a)] < position[static_cast<std::size_t>(b)];
  });
  order.insert(order.end(), rest.begin(), rest.end());
  std::vector<int> new_index(boxes.size());
  std::vector<DetectedBox> sorted;
  sorted.reserve(boxes.size());
  for (std::size_t j = 0; j < order.size(); ++j) {
    new_index[static_cast<std::size_t>(order[j])] = static_cast<int>(j);
    sorted.push_back(std::move(boxes[static_cast<std::size_t>(order[j])]));
    sorted.back().pick_index = static_cast<int>(j);
  }
  boxes = std::move(sorted);

  std::vector<PickGroup> groups;
  for (const Pick& pick : now) {
    PickGroup group;
    for (const int i : pick.boxes) group.boxes.push_back(new_index[static_cast<std::size_t>(i)]);
    std::sort(group.boxes.begin(), group.boxes.end());
    group.tcp = check.tcp(pick.footprint);
    groups.push_back(std::move(group));
  }
  std::sort(groups.begin(), groups.end(),
            [](const PickGroup& a, const PickGroup& b) { return a.boxes.front() < b.boxes.front(); });
  for (std::size_t g = 0; g < groups.size(); ++g) groups[g].pick_index = static_cast<int>(g);
  return groups;
}

}  // namespace palletd
