// palletd io: the recorded frame format (shared/spec/frames.md) and its truth file.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "palletd/expected.hpp"
#include "palletd/frame.hpp"
#include "palletd/geometry.hpp"

namespace palletd {

/// Reads STEM.depth.png, STEM.json and, when present, STEM.intensity.png.
/// Errors name the file and the problem (missing file, 8-bit or colour depth, size mismatch,
/// missing or wrong-typed key, non-positive focal length or depth_scale, truncated PNG).
Expected<Frame> read_frame(const std::string& stem);

/// Writes STEM.depth.png, STEM.json and STEM.intensity.png (when the frame has intensity).
/// Each file is written to a temporary name and renamed, so no half-written file is left.
Status write_frame(const std::string& stem, const Frame& frame);

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
  std::vector<std::string> recipe;                 ///< format names
  std::vector<std::array<int, 2>> recipe_mm;       ///< [long, short] per recipe format [mm]
};

Expected<Truth> read_truth(const std::string& stem);
Status write_truth(const std::string& stem, const Truth& truth);

/// Frame stems (paths without ".depth.png") in a folder, sorted by name.
Expected<std::vector<std::string>> list_frame_stems(const std::string& directory);

}  // namespace palletd
