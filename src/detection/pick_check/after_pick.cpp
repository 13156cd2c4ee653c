// after_pick(): the last result brought up to date by a pick check (pick_check.hpp).
#include <algorithm>

#include "palletd/detection/pick_check.hpp"
#include "palletd/detection/picking.hpp"

namespace palletd {

Detection after_pick(const Detection& last, const PickCheck& check, const Frame& after,
                     const DetectionParams& params) {
  if (check.verdict == PickVerdict::kFailed || check.boxes.size() != last.boxes.size()) return last;
  Detection out = last;
  out.boxes.clear();
  out.groups.clear();
  for (const BoxCheck& c : check.boxes)
    if (c.present) out.boxes.push_back(c.now);
  std::stable_sort(out.boxes.begin(), out.boxes.end(),
                   [](const DetectedBox& a, const DetectedBox& b) { return a.pick_index < b.pick_index; });
  for (std::size_t i = 0; i < out.boxes.size(); ++i) {
    out.boxes[i].pick_index = static_cast<int>(i);
    out.boxes[i].pick.reset();
  }
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
