// after_pick(): the last result brought up to date by a pick check (pick_check.hpp).
#include <algorithm>
#include <vector>

#include "palletd/detection/pick_check.hpp"
#include "palletd/detection/picking.hpp"

namespace palletd {

Detection after_pick(const Detection& last, const PickCheck& check, const Frame& after,
                     const DetectionParams& params) {
  if (check.verdict == PickVerdict::kFailed || check.boxes.size() != last.boxes.size()) return last;
  Detection out = last;
  out.boxes.clear();
  out.groups.clear();
  // The boxes left in the last pick order (an index sort: the boxes themselves are not moved).
  std::vector<const BoxCheck*> left;
  for (const BoxCheck& c : check.boxes)
    if (c.present) left.push_back(&c);
  std::stable_sort(left.begin(), left.end(), [&](const BoxCheck* a, const BoxCheck* b) {
    return last.boxes[static_cast<std::size_t>(a->box)].pick_index <
           last.boxes[static_cast<std::size_t>(b->box)].pick_index;
  });
  for (const BoxCheck* c : left) {
    DetectedBox& box = out.boxes.emplace_back(c->now);
    box.pick_index = static_cast<int>(out.boxes.size()) - 1;
    box.pick.reset();
  }
  out.layer.diagnostics.side_steps_facing_m = check.side_steps_facing_m;
  out.layer.diagnostics.side_steps_away_m = check.side_steps_away_m;
  out.timing_ms = check.timing_ms;
  out.message = std::string("after a pick (") + to_string(check.verdict) + "): " + check.message;
  if (params.gripper && !out.boxes.empty()) {
    const RayTable rays(after.intrinsics);
    const PickSurroundings surroundings{
        out.layer.T_camera_layer,
        obstacles_above_layer(after, rays, out.layer.T_camera_layer,
                              1e-3 * params.gripper->obstacle_height_mm, params.roi ? &*params.roi : nullptr,
                              after.T_base_camera),
        params.roi, after.T_base_camera, after.intrinsics};
    out.groups = plan_picks(surroundings, *params.gripper, out.boxes);
  }
  return out;
}

}  // namespace palletd
