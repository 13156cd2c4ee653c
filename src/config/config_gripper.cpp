// The `gripper` section: null (no picking help), or the tool seen from above
// (docs/commissioning.md, "Gripper and pick groups").
#include "config_yaml.hpp"

namespace palletd::config_detail {

namespace {

/// [a, b]: two numbers, each checked against [lo, hi].
Eigen::Vector2d read_pair(const Context& ctx, const YAML::Node& node, const std::string& path, double lo,
                          double hi, const std::string& what) {
  if (!node.IsSequence() || node.size() != 2)
    fail(ctx, node, path, "expected a list of 2 numbers " + what + ", got " + describe(node));
  Eigen::Vector2d out;
  for (std::size_t i = 0; i < 2; ++i) {
    out[static_cast<Eigen::Index>(i)] = read_double(ctx, node[i], index_path(path, i));
    if (out[static_cast<Eigen::Index>(i)] < lo || out[static_cast<Eigen::Index>(i)] > hi)
      fail(ctx, node[i], index_path(path, i),
           "must be between " + std::to_string(lo) + " and " + std::to_string(hi));
  }
  return out;
}

double read_bounded(const Context& ctx, const YAML::Node& node, const std::string& path, double lo,
                    double hi) {
  const double v = read_double(ctx, node, path);
  if (v < lo || v > hi)
    fail(ctx, node, path, "must be between " + std::to_string(lo) + " and " + std::to_string(hi));
  return v;
}

}  // namespace

std::optional<GripperParams> read_gripper(const Context& ctx, const YAML::Node& node,
                                          const std::string& path) {
  if (node.IsNull()) return std::nullopt;
  if (!node.IsMap())
    fail(ctx, node, path, "expected a mapping {footprint_mm, ...} or null, got " + describe(node));
  check_keys(ctx, node, path,
             {"footprint_mm", "tcp_offset_mm", "max_boxes", "clearance_mm", "yaw_limits_deg",
              "max_group_gap_mm", "obstacle_height_mm"});
  GripperParams g;
  g.footprint_mm = read_pair(ctx, require(ctx, node, path, "footprint_mm"), join(path, "footprint_mm"), 1.0,
                             5000.0, "[L, W] in millimetres");
  if (const YAML::Node n = node["tcp_offset_mm"])
    g.tcp_offset_mm =
        read_pair(ctx, n, join(path, "tcp_offset_mm"), -5000.0, 5000.0, "[x, y] in millimetres");
  if (const YAML::Node n = node["max_boxes"]) {
    const long long v = read_integer(ctx, n, join(path, "max_boxes"));
    if (v < 1 || v > 10) fail(ctx, n, join(path, "max_boxes"), "must be between 1 and 10");
    g.max_boxes = static_cast<int>(v);
  }
  if (const YAML::Node n = node["clearance_mm"])
    g.clearance_mm = read_bounded(ctx, n, join(path, "clearance_mm"), 0.0, 1000.0);
  if (const YAML::Node n = node["yaw_limits_deg"]) {
    const std::string ypath = join(path, "yaw_limits_deg");
    const Eigen::Vector2d y = read_pair(ctx, n, ypath, -360.0, 360.0, "[min, max] in degrees");
    if (!(y.x() < y.y())) fail(ctx, n, ypath, "the minimum must be below the maximum");
    if (y.y() - y.x() > 360.0) fail(ctx, n, ypath, "must not span more than 360 degrees");
    g.yaw_min_deg = y.x();
    g.yaw_max_deg = y.y();
  }
  if (const YAML::Node n = node["max_group_gap_mm"])
    g.max_group_gap_mm = read_bounded(ctx, n, join(path, "max_group_gap_mm"), 0.0, 200.0);
  if (const YAML::Node n = node["obstacle_height_mm"])
    g.obstacle_height_mm = read_bounded(ctx, n, join(path, "obstacle_height_mm"), 5.0, 2000.0);
  return g;
}

}  // namespace palletd::config_detail
