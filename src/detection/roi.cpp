// The work volume applied to the organized cloud (roi.hpp).
#include "roi.hpp"

#include <limits>

namespace palletd {

namespace {

/// Below the region (base frame: lower than min_m.z; camera frame: further than max_m.z): the
/// floor, a lower level. Such points stay, wherever they lie, because they show where the layer
/// ends: a tilted camera sees the floor beyond a layer's far edge well outside the footprint, and
/// without it that edge would look like one where the depth ends.
bool below_region(const RegionOfInterest& roi, const Eigen::Vector3d& q) {
  return roi.frame == RegionOfInterest::Frame::kBase ? q.z() < roi.min_m.z() : q.z() > roi.max_m.z();
}

}  // namespace

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
    const Eigen::Vector3d q = T_roi_camera * p.cast<double>();
    if (roi.contains(q) || below_region(roi, q)) continue;
    p = Eigen::Vector3f(nan, nan, nan);
  }
  return {};
}

}  // namespace palletd
