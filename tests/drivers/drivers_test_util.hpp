// Helpers for the driver tests: temporary folders and synthetic depth frames.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "palletd/core/frame.hpp"

namespace palletd::test {

/// A fresh folder under the build tree's temp area, removed again at the end of the scope.
class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    static int counter = 0;
    path_ = std::filesystem::temp_directory_path() /
            ("palletd-drivers-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

/// A seeded synthetic frame: a tilted floor with a raised box and a few holes (depth 0).
/// Depth in millimetres (depth_scale_m = 0.001), values 1200..2600.
inline Frame synthetic_frame(int width, int height, std::uint32_t seed) {
  Frame f;
  f.intrinsics.width = width;
  f.intrinsics.height = height;
  f.intrinsics.fx = f.intrinsics.fy = 0.9 * width;
  f.intrinsics.cx = (width - 1) / 2.0;
  f.intrinsics.cy = (height - 1) / 2.0;
  f.depth_scale_m = 0.001;
  f.camera_id = "synthetic-" + std::to_string(seed);
  f.timestamp_ns = 1000 + seed;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-3, 3);
  std::uniform_int_distribution<int> hole(0, 40);
  const int bx = 10 + static_cast<int>(seed % 7), by = 8 + static_cast<int>(seed % 5);
  f.depth.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      int z = 2400 + u + v / 2 + noise(rng);
      if (u >= bx && u < bx + width / 3 && v >= by && v < by + height / 3) z -= 900;
      if (hole(rng) == 0) z = 0;
      f.depth[static_cast<std::size_t>(v * width + u)] = static_cast<std::uint16_t>(z);
    }
  }
  return f;
}

}  // namespace palletd::test
