#include "png_util.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace palletd::test {

namespace fs = std::filesystem;

TempDir::TempDir() {
  std::string pattern = (fs::temp_directory_path() / "palletd-io-test-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path_ = pattern;
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

Frame make_frame(int width, int height, double depth_scale_m) {
  Frame f;
  f.intrinsics.width = width;
  f.intrinsics.height = height;
  f.intrinsics.fx = 475.1;
  f.intrinsics.fy = 498.9;
  f.intrinsics.cx = (width - 1) / 2.0;
  f.intrinsics.cy = (height - 1) / 2.0;
  f.depth_scale_m = depth_scale_m;
  f.depth.resize(f.pixel_count());
  for (std::size_t i = 0; i < f.depth.size(); ++i)
    f.depth[i] = (i % 7 == 3) ? std::uint16_t{0} : static_cast<std::uint16_t>(1000 + 37 * i % 60000);
  f.camera_id = "test-0001";
  f.timestamp_ns = 1234567890123456789LL;
  return f;
}

void write_png_file(const std::string& path, const cv::Mat& image) {
  if (!cv::imwrite(path, image)) throw std::runtime_error("cannot write " + path);
}

void write_text_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path);
}

std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void truncate_file(const std::string& path, std::size_t keep) { fs::resize_file(path, keep); }

}  // namespace palletd::test
