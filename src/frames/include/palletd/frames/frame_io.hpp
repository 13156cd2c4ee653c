// palletd frames: the recorded frame format (shared/spec/frames.md) and its truth file.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/core/truth.hpp"

namespace palletd {

/// A frame's depth file is its stem followed by this; a frame is listed by it.
inline constexpr const char* kDepthFileSuffix = ".depth.png";

/// Reads STEM.depth.png, STEM.json and, when present, STEM.intensity.png.
/// Errors name the file and the problem (missing file, 8-bit or colour depth, size mismatch,
/// missing or wrong-typed key, non-positive focal length or depth_scale, truncated PNG).
Expected<Frame> read_frame(const std::string& stem);

/// Writes STEM.depth.png, STEM.json and STEM.intensity.png (when the frame has intensity).
/// Each file is written to a temporary name and renamed, so no half-written file is left.
Status write_frame(const std::string& stem, const Frame& frame);

Expected<Truth> read_truth(const std::string& stem);
Status write_truth(const std::string& stem, const Truth& truth);

/// Frame stems (paths without ".depth.png") in a folder, sorted by name.
Expected<std::vector<std::string>> list_frame_stems(const std::string& directory);

}  // namespace palletd
