// Detection -> the PLC's result record (engineering units; the register map scales them).
#pragma once

#include <cstdint>
#include <optional>

#include <Eigen/Geometry>

#include "palletd/detection/detection.hpp"
#include "palletd/modbus/register_map.hpp"

namespace palletd {

/// Fills the result record of a detection that ran. Poses in the base frame when `T_base_camera`
/// is known (each box then carries base_position), else in the camera frame. The pick fields are
/// set when the boxes carry pick data (a gripper is configured and boxes were found); the TCP
/// poses are in the frame their TcpPose says, which follows `T_base_camera` the same way.
modbus::ResultRecord to_result_record(const Detection& detection, bool base_frame);

/// The register 870 + i status of a box: pickable, or what blocks it.
modbus::PickStatus pick_status_of(const BoxPick& pick);

/// Marks `record` a failed trigger: status kFailed with `code` and `detail`, no boxes.
void mark_failed(modbus::ResultRecord& record, modbus::ErrorCode code, std::uint16_t detail);

/// The register-102 detail of a failed detection.
modbus::DetectionFailure failure_of(DetectionStatus status);

}  // namespace palletd
