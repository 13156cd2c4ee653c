// Test helpers for the io tests: temporary folders and hand-made frame files.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "palletd/core/frame.hpp"

namespace palletd::test {

/// A fresh folder under the system temp dir, removed with everything in it on destruction.
class TempDir {
 public:
  TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  ~TempDir();
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

/// A small frame with a depth ramp, some zero pixels and the given depth scale.
Frame make_frame(int width, int height, double depth_scale_m);

void write_png_file(const std::string& path, const cv::Mat& image);
void write_text_file(const std::string& path, const std::string& text);
std::string read_whole_file(const std::string& path);
/// Cuts a file to `keep` bytes.
void truncate_file(const std::string& path, std::size_t keep);

}  // namespace palletd::test
