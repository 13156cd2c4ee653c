// palletd core: the ground truth of a frame (STEM.truth.json, shared/spec/frames.md) as values.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "palletd/core/geometry.hpp"

namespace palletd {

/// One box of the truth file, camera frame [m].
struct TruthBox {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d long_axis = Eigen::Vector3d::UnitX();
  Eigen::Vector3d normal = -Eigen::Vector3d::UnitZ();
  double long_m = 0.0, short_m = 0.0;
  std::string format;
};

/// STEM.truth.json: for evaluation code and the simulator only; a detector never reads it.
struct Truth {
  std::vector<TruthBox> boxes;
  Plane layer_plane;
  std::vector<std::string> recipe;            ///< format names
  std::vector<std::array<int, 2>> recipe_mm;  ///< [long, short] per recipe format [mm]
  std::string expect = "boxes";  ///< what the detector must answer: boxes, empty, slip_sheet
};

}  // namespace palletd
