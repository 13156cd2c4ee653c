#include "frame_problem.hpp"

#include <cmath>

namespace palletd {

std::string frame_problem(const Frame& frame) {
  const Intrinsics& in = frame.intrinsics;
  if (in.width <= 0 || in.height <= 0) return "frame has no size";
  if (!(in.fx > 0.0) || !(in.fy > 0.0) || !std::isfinite(in.fx) || !std::isfinite(in.fy))
    return "focal length must be positive";
  if (!std::isfinite(in.cx) || !std::isfinite(in.cy)) return "principal point is not finite";
  if (frame.depth.size() != frame.pixel_count())
    return "depth has " + std::to_string(frame.depth.size()) + " pixels, expected " +
           std::to_string(frame.pixel_count());
  if (!(frame.depth_scale_m > 0.0) || !std::isfinite(frame.depth_scale_m)) return "depth_scale must be positive";
  return {};
}

}  // namespace palletd
