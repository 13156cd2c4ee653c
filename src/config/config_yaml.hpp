// palletd config, private: the configuration's own sections (the modules' tables are theirs:
// camera_config_table.hpp, server_config_table.hpp, web_config_table.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "palletd/config/config.hpp"
#include "palletd/config_table/table.hpp"
#include "palletd/drivers/camera_config_table.hpp"
#include "palletd/modbus/server_config_table.hpp"
#include "palletd/web/web_config_table.hpp"

namespace palletd::config_detail {

using namespace config_table;

// The configuration's own tables (config_fields.cpp); the modules' are camera_table(),
// modbus::server_table() and web_table().
const Table<DetectionParams>& detection_table();
const Table<PalletParams>& pallet_table();
const Table<PipelineConfig>& pipeline_table();
const Table<LoggingConfig>& logging_table();
const Table<RecordingConfig>& recording_table();
const Table<HealthConfig>& health_table();
const Table<PickCheckParams>& check_table();

// Sections with their own shape (config_sections.cpp).
std::optional<Eigen::Isometry3d> read_camera_to_base(const Context& ctx, const YAML::Node& node,
                                                     const std::string& path);
/// detection.roi: null, or {frame: base | camera, min_m: [x, y, z], max_m: [x, y, z]} with
/// min < max on every axis.
std::optional<RegionOfInterest> read_roi(const Context& ctx, const YAML::Node& node, const std::string& path);
/// gripper: null, or {footprint_mm: [L, W], tcp_offset_mm, max_boxes, clearance_mm,
/// yaw_limits_deg: [min, max], max_group_gap_mm, obstacle_height_mm} (config_gripper.cpp).
std::optional<GripperParams> read_gripper(const Context& ctx, const YAML::Node& node, const std::string& path);
std::vector<BoxFormat> read_formats(const Context& ctx, const YAML::Node& node, const std::string& path);
std::vector<Recipe> read_recipes(const Context& ctx, const YAML::Node& node, const std::string& path,
                                 const std::vector<BoxFormat>& formats);

}  // namespace palletd::config_detail
