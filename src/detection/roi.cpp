// The work volume applied to the organized cloud (roi.hpp).
#include "roi.hpp"

#include <limits>

namespace palletd {

std::string apply_region_of_interest(const RegionOfInterest& roi, const std::optional<Eigen::Isometry3d>& T_base_camera,
                                     OrganizedCloud& cloud) {
  const bool in_base = roi.frame == RegionOfInterest::Frame::kBase;
  if (in_base && !T_base_camera) {
    return "detection.roi is given in the base frame, but the frame has no camera_to_base (set it in the "
           "configuration or the frame's JSON)";
  }
  const Eigen::Isometry3d T_roi_camera = in_base ? *T_base_camera : Eigen::Isometry3d::Identity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (Eigen::Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    if (!roi.contains(T_roi_camera * p.cast<double>())) p = Eigen::Vector3f(nan, nan, nan);
  }
  return {};
}

}  // namespace palletd
