// palletd io: one detection as one JSON line (shared/spec/detections.md), and back.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "palletd/detection/detection.hpp"
#include "palletd/core/expected.hpp"
#include "palletd/core/geometry.hpp"

namespace palletd {

/// The JSON Lines record of one frame, without a trailing newline:
/// frame, status, message, timing_ms{total, ...}, layer{plane, area_m2, coverage}, ambiguous,
/// budget_exhausted, clipped_by_image_border, outline_unobserved,
/// boxes[{center, long_axis, normal, size, format, score, partly_unseen, base{position, yaw_deg}?,
/// pick_index}].
std::string detection_to_json_line(const Detection& detection, const std::string& frame_stem);

/// One box of a parsed detection line, camera frame [m].
struct ParsedBox {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d long_axis = Eigen::Vector3d::UnitX();
  Eigen::Vector3d normal = -Eigen::Vector3d::UnitZ();
  double long_m = 0.0, short_m = 0.0;
  int format = 0;
  double score = 0.0;
  int pick_index = 0;
  bool partly_unseen = false;  ///< absent in the line: false
  std::optional<Eigen::Vector3d> base_position;  ///< [m]
  std::optional<double> base_yaw_deg;            ///< [deg]
};

/// A detection line read back, for evaluation tools.
struct ParsedDetection {
  std::string frame;
  std::string status;  ///< "ok", "no_plane", ...
  std::string message;
  std::map<std::string, double> timing_ms;
  Plane plane;
  double area_m2 = 0.0;
  double coverage = 0.0;
  bool ambiguous = false;
  std::string ambiguity_reason;
  std::optional<double> height_above_pallet_m;
  std::optional<int> layers_remaining;
  std::vector<ParsedBox> boxes;
};

/// Parses one line written by detection_to_json_line (or any writer of the spec). Required:
/// frame, status, boxes; the other keys take their defaults when absent; extra keys are ignored.
Expected<ParsedDetection> parse_detection_line(const std::string& line);

}  // namespace palletd
