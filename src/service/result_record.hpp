// Detection -> the PLC's result record (engineering units; the register map scales them).
#pragma once

#include <optional>

#include <Eigen/Geometry>

#include "palletd/detection/detection.hpp"
#include "palletd/modbus/register_map.hpp"

namespace palletd {

/// Fills the result record of a detection that ran. Poses in the base frame when `T_base_camera`
/// is known (each box then carries base_position), else in the camera frame.
modbus::ResultRecord to_result_record(const Detection& detection, bool base_frame);

/// The register-102 detail of a failed detection.
modbus::DetectionFailure failure_of(DetectionStatus status);

}  // namespace palletd
