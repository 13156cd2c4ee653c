// The checks of one footprint placement: the region of interest's walls, what stands higher than
// the layer, the robot's yaw limits, and neighbours under the footprint.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "palletd/core/geometry.hpp"

#include "pick_internal.hpp"

namespace palletd {

const char* to_string(PickBlock block) {
  switch (block) {
    case PickBlock::kNone:
      return "";
    case PickBlock::kRoi:
      return "roi";
    case PickBlock::kHigherLevel:
      return "higher_level";
    case PickBlock::kYawLimits:
      return "yaw_limits";
    case PickBlock::kNeighbour:
      return "neighbour";
  }
  return "";
}

namespace {

/// Whether camera-frame point `p` stands between the region's walls (any height): what stands
/// above the region's top is still in the robot's way.
bool between_walls(const Eigen::Vector3d& p, const RegionOfInterest* roi,
                   const Eigen::Isometry3d& T_roi_camera) {
  if (roi == nullptr) return true;
  const Eigen::Vector3d q = T_roi_camera * p;
  return q.x() >= roi->min_m.x() && q.x() <= roi->max_m.x() && q.y() >= roi->min_m.y() &&
         q.y() <= roi->max_m.y();
}

/// Calls f(j) for each pixel j of the 3 x 3 around pixel i (itself too), in an image `w` wide.
template <typename F>
void around(std::size_t i, int w, F&& f) {
  const auto at = static_cast<std::ptrdiff_t>(i), row = static_cast<std::ptrdiff_t>(w);
  for (std::ptrdiff_t dv = -1; dv <= 1; ++dv) {
    for (std::ptrdiff_t du = -1; du <= 1; ++du) f(static_cast<std::size_t>(at + dv * row + du));
  }
}

/// The pixels above the layer that stand for an obstacle: each with at least three of its eight
/// neighbours above too (a lone pixel or a line one pixel wide is noise), less the outer ring of
/// a solid obstacle (pixels beside one whose eight neighbours are all above). That ring holds the
/// pixels that straddle the obstacle's edge: a time-of-flight camera mixes the obstacle's top with
/// what lies below it, a stereo camera fattens the top over its shadow, and both put them outside
/// the obstacle, up to a pixel or more. The clearance covers the pixel an obstacle may lose. A
/// thin obstacle (a bar two pixels wide) has no such inside and is kept whole.
std::vector<std::uint8_t> obstacle_pixels(const std::vector<std::uint8_t>& above, int w, int h) {
  std::vector<std::uint8_t> count(above.size(), 0);  // pixels above in the 3 x 3 around each
  for (int v = 1; v + 1 < h; ++v) {
    for (int u = 1; u + 1 < w; ++u) {
      const std::size_t i =
          static_cast<std::size_t>(v) * static_cast<std::size_t>(w) + static_cast<std::size_t>(u);
      if (above[i] == 0) continue;
      int n = 0;
      around(i, w, [&](std::size_t j) { n += above[j]; });
      count[i] = static_cast<std::uint8_t>(n);
    }
  }
  std::vector<std::uint8_t> kept(above.size(), 0);
  for (int v = 1; v + 1 < h; ++v) {
    for (int u = 1; u + 1 < w; ++u) {
      const std::size_t i =
          static_cast<std::size_t>(v) * static_cast<std::size_t>(w) + static_cast<std::size_t>(u);
      if (count[i] < 4) continue;  // itself and three neighbours
      bool beside_inside = false;
      around(i, w, [&](std::size_t j) { beside_inside = beside_inside || count[j] == 9; });
      kept[i] = count[i] == 9 || !beside_inside ? 1 : 0;
    }
  }
  return kept;
}

}  // namespace

std::vector<Eigen::Vector2d> obstacles_above_layer(const Frame& frame, const RayTable& rays,
                                                   const Eigen::Isometry3d& T_camera_layer,
                                                   double min_height_m, const RegionOfInterest* roi,
                                                   const std::optional<Eigen::Isometry3d>& T_base_camera) {
  const Eigen::Isometry3d T_layer_camera = T_camera_layer.inverse();
  const bool in_base = roi != nullptr && roi->frame == RegionOfInterest::Frame::kBase;
  if (in_base && !T_base_camera) return {};  // detect() refuses such a region before
  const Eigen::Isometry3d T_roi_camera = in_base ? *T_base_camera : Eigen::Isometry3d::Identity();
  const int w = frame.intrinsics.width, h = frame.intrinsics.height;
  auto point_of = [&](std::size_t i) {
    const double z_m = static_cast<double>(frame.depth[i]) * frame.depth_scale_m;
    return Eigen::Vector3d(rays.ray(i).x() * z_m, rays.ray(i).y() * z_m, z_m);
  };
  // Height above the layer of a camera point: the layer frame's z row.
  const Eigen::RowVector3d up = T_layer_camera.linear().row(2);
  const double up_offset = T_layer_camera.translation().z();
  std::vector<std::uint8_t> above(frame.pixel_count(), 0);
  for (std::size_t i = 0; i < frame.pixel_count(); ++i) {
    if (frame.depth[i] == 0) continue;
    const Eigen::Vector3d p = point_of(i);
    if (up.dot(p) + up_offset > min_height_m && between_walls(p, roi, T_roi_camera)) above[i] = 1;
  }
  constexpr double kCell_m = 0.005;
  // A cell's key: its two 32-bit signed indices side by side in one unsigned word.
  std::vector<std::uint64_t> cells;
  const std::vector<std::uint8_t> kept = obstacle_pixels(above, w, h);
  for (int v = 1; v + 1 < h; ++v) {
    for (int u = 1; u + 1 < w; ++u) {
      const std::size_t i =
          static_cast<std::size_t>(v) * static_cast<std::size_t>(w) + static_cast<std::size_t>(u);
      if (kept[i] == 0) continue;
      const Eigen::Vector3d q = T_layer_camera * point_of(i);
      const auto cx = static_cast<std::int32_t>(std::floor(q.x() / kCell_m));
      const auto cy = static_cast<std::int32_t>(std::floor(q.y() / kCell_m));
      cells.push_back((std::uint64_t{static_cast<std::uint32_t>(cx)} << 32) | static_cast<std::uint32_t>(cy));
    }
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  std::vector<Eigen::Vector2d> out;
  out.reserve(cells.size());
  for (const std::uint64_t key : cells) {
    const auto cx = static_cast<double>(static_cast<std::int32_t>(static_cast<std::uint32_t>(key >> 32)));
    const auto cy = static_cast<double>(static_cast<std::int32_t>(static_cast<std::uint32_t>(key & 0xffffffffu)));
    out.emplace_back((cx + 0.5) * kCell_m, (cy + 0.5) * kCell_m);
  }
  return out;
}

namespace picking {

namespace {

Eigen::Vector2d perpendicular(const Eigen::Vector2d& u) { return {-u.y(), u.x()}; }

/// Half the rectangle's extent along the unit direction `d`.
double half_extent(const Rect& r, const Eigen::Vector2d& d) {
  return r.half_long_m * std::abs(r.axis.dot(d)) + r.half_short_m * std::abs(perpendicular(r.axis).dot(d));
}

/// Footprints may reach this far over a neighbour's edge: the neighbour's measured edge is no
/// more certain than that, and a vacuum field that just touches a seam does not lift the box.
constexpr double kNeighbourTolerance_m = 0.005;

/// Whether `yaw_deg` lies within [lo, hi] (limits may reach past ±180).
bool within_limits(double yaw_deg, double lo_deg, double hi_deg) {
  for (const double y : {yaw_deg - 360.0, yaw_deg, yaw_deg + 360.0})
    if (y >= lo_deg && y <= hi_deg) return true;
  return false;
}

double angular_distance_deg(double a_deg, double b_deg) {
  const double d = std::fmod(std::abs(a_deg - b_deg), 360.0);
  return std::min(d, 360.0 - d);
}

}  // namespace

bool Rect::contains(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d d = p - center;
  return std::abs(d.dot(axis)) <= half_long_m && std::abs(d.dot(perpendicular(axis))) <= half_short_m;
}

Rect Rect::grown(double margin_m) const {
  Rect r = *this;
  r.half_long_m = std::max(0.0, half_long_m + margin_m);
  r.half_short_m = std::max(0.0, half_short_m + margin_m);
  return r;
}

std::array<Eigen::Vector2d, 4> Rect::corners() const {
  const Eigen::Vector2d a = half_long_m * axis;
  const Eigen::Vector2d b = half_short_m * perpendicular(axis);
  return {center - a - b, center + a - b, center + a + b, center - a + b};
}

bool overlap(const Rect& a, const Rect& b) {
  const Eigen::Vector2d d = b.center - a.center;
  for (const Eigen::Vector2d& axis : {a.axis, perpendicular(a.axis), b.axis, perpendicular(b.axis)}) {
    if (std::abs(d.dot(axis)) >= half_extent(a, axis) + half_extent(b, axis)) return false;
  }
  return true;
}

Rect rect_of(const Box2d& box) {
  Rect r;
  r.center = box.center;
  r.axis = Eigen::Vector2d(std::cos(box.yaw_rad), std::sin(box.yaw_rad));
  r.half_long_m = 0.5 * box.long_m;
  r.half_short_m = 0.5 * box.short_m;
  return r;
}

PlacementCheck::PlacementCheck(const PickSurroundings& surroundings, const GripperParams& gripper,
                               const std::vector<DetectedBox>& boxes)
    : surroundings_(surroundings), gripper_(gripper) {
  box_rects_.reserve(boxes.size());
  for (const DetectedBox& b : boxes) box_rects_.push_back(rect_of(b.in_layer));
}

bool PlacementCheck::inside_roi(const Rect& area) const {
  if (!surroundings_.roi) return true;
  const RegionOfInterest& roi = *surroundings_.roi;
  const bool base = roi.frame == RegionOfInterest::Frame::kBase;
  if (base && !surroundings_.T_base_camera) return true;  // detect() refuses such a region before
  for (const Eigen::Vector2d& c : area.corners()) {
    Eigen::Vector3d p = surroundings_.T_camera_layer * Eigen::Vector3d(c.x(), c.y(), 0.0);
    if (base) p = *surroundings_.T_base_camera * p;
    // The walls: x and y. The footprint is at the layer's height, which is inside the region.
    if (p.x() < roi.min_m.x() || p.x() > roi.max_m.x() || p.y() < roi.min_m.y() || p.y() > roi.max_m.y())
      return false;
  }
  return true;
}

bool PlacementCheck::in_view(const Rect& area) const {
  const Intrinsics& k = surroundings_.intrinsics;
  if (!k.valid()) return true;
  constexpr double kBorder_px = 2.0;  // the border pixels' depth is the least certain
  for (const Eigen::Vector2d& c : area.corners()) {
    const Eigen::Vector3d p = surroundings_.T_camera_layer * Eigen::Vector3d(c.x(), c.y(), 0.0);
    if (!(p.z() > 0.0)) return false;
    const double u = k.fx * p.x() / p.z() + k.cx, v = k.fy * p.y() / p.z() + k.cy;
    if (u < kBorder_px || v < kBorder_px || u > k.width - 1 - kBorder_px || v > k.height - 1 - kBorder_px)
      return false;
  }
  return true;
}

bool PlacementCheck::obstacle_in(const Rect& area) const {
  return std::any_of(surroundings_.obstacles_layer_m.begin(), surroundings_.obstacles_layer_m.end(),
                     [&](const Eigen::Vector2d& p) { return area.contains(p); });
}

TcpPose PlacementCheck::pose_of(const Rect& footprint, const Eigen::Vector2d& axis) const {
  const Eigen::Vector2d offset_m = 1e-3 * gripper_.tcp_offset_mm;
  const Eigen::Vector2d tcp_layer =
      footprint.center + offset_m.x() * axis + offset_m.y() * perpendicular(axis);
  TcpPose pose;
  pose.position_m = surroundings_.T_camera_layer * Eigen::Vector3d(tcp_layer.x(), tcp_layer.y(), 0.0);
  Eigen::Vector3d direction =
      surroundings_.T_camera_layer.linear() * Eigen::Vector3d(axis.x(), axis.y(), 0.0);
  if (surroundings_.T_base_camera) {
    pose.position_m = *surroundings_.T_base_camera * pose.position_m;
    direction = surroundings_.T_base_camera->linear() * direction;
    pose.base_frame = true;
  }
  pose.yaw_deg = yaw_deg_of(direction);
  return pose;
}

TcpPose PlacementCheck::tcp(const Rect& footprint, bool* reachable) const {
  const double middle_deg = 0.5 * (gripper_.yaw_min_deg + gripper_.yaw_max_deg);
  std::optional<TcpPose> best;
  TcpPose closest;
  double closest_deg = 1e9;
  for (const Eigen::Vector2d& axis : {footprint.axis, Eigen::Vector2d(-footprint.axis)}) {
    const TcpPose pose = pose_of(footprint, axis);
    const double distance_deg = angular_distance_deg(pose.yaw_deg, middle_deg);
    if (distance_deg < closest_deg) {
      closest_deg = distance_deg;
      closest = pose;
    }
    if (!within_limits(pose.yaw_deg, gripper_.yaw_min_deg, gripper_.yaw_max_deg)) continue;
    if (!best || distance_deg < angular_distance_deg(best->yaw_deg, middle_deg)) best = pose;
  }
  if (reachable != nullptr) *reachable = best.has_value();
  return best ? *best : closest;
}

PickBlock PlacementCheck::lasting_block(const Pick& pick) {
  // Placements differ by the footprint's turn and its shift off the boxes' centre (millimetres).
  const Eigen::Vector2d& c = pick.footprint.center;
  const auto key = std::make_tuple(pick.boxes, std::lround(1e3 * c.x()), std::lround(1e3 * c.y()),
                                   std::lround(1e3 * pick.footprint.axis.x()));
  if (const auto it = lasting_.find(key); it != lasting_.end()) return it->second;
  const Rect clear_area = pick.footprint.grown(1e-3 * gripper_.clearance_mm);
  bool reachable = false;
  (void)tcp(pick.footprint, &reachable);
  PickBlock block = PickBlock::kNone;
  if (!inside_roi(clear_area) || !in_view(clear_area))
    block = PickBlock::kRoi;
  else if (obstacle_in(clear_area))
    block = PickBlock::kHigherLevel;
  else if (!reachable)
    block = PickBlock::kYawLimits;
  lasting_.emplace(key, block);
  return block;
}

bool PlacementCheck::covers_neighbour(const Pick& pick, const std::vector<char>& standing) const {
  const Rect footprint = pick.footprint.grown(-kNeighbourTolerance_m);
  for (std::size_t j = 0; j < box_rects_.size(); ++j) {
    if (standing[j] == 0 || std::binary_search(pick.boxes.begin(), pick.boxes.end(), static_cast<int>(j)))
      continue;
    if (overlap(footprint, box_rects_[j])) return true;
  }
  return false;
}

}  // namespace picking
}  // namespace palletd
