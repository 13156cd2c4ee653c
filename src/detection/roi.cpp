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
  const Eigen::Matrix3d R = T_roi_camera.linear();
  const Eigen::Vector3d t = T_roi_camera.translation();
  // One row of T_roi_camera applied to p: the coordinate `row` of the point in the region's frame.
  auto coordinate = [&](int row, const Eigen::Vector3f& p) {
    return R(row, 0) * p.x() + R(row, 1) * p.y() + R(row, 2) * p.z() + t(row);
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (Eigen::Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    // Below the region (base frame: lower than min_m.z; camera frame: further than max_m.z): the
    // floor, a lower level. Such points stay wherever they lie, because they show where the layer
    // ends: a tilted camera sees the floor beyond a layer's far edge well outside the footprint.
    const double z = coordinate(2, p);
    if (in_base ? z < roi.min_m.z() : z > roi.max_m.z()) continue;
    const Eigen::Vector3d q(coordinate(0, p), coordinate(1, p), z);
    if (!roi.contains(q)) p = Eigen::Vector3f(nan, nan, nan);
  }
  return {};
}

}  // namespace palletd
