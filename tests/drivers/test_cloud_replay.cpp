// Replay of organized PCD / PLY clouds: a bundled frame written as a cloud with PCL plays back as
// the same frame (depth in 0.1 mm, intrinsics estimated), and gives the same detection.
#include <catch2/catch.hpp>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include "detection_compare.hpp"
#include "drivers_test_util.hpp"
#include "palletd/frames/frame_io.hpp"
#include "replay/cloud_frame.hpp"
#include "replay/replay_camera.hpp"

using namespace palletd;
using palletd::test::TempDir;
using std::chrono::milliseconds;
namespace fs = std::filesystem;

namespace {

const std::string kXtion = std::string(PALLETD_TEST_DATA_DIR) + "/22_block_600x400_xtion";

/// The frame as an organized XYZI cloud in the camera frame [m]; NaN where depth is 0.
pcl::PointCloud<pcl::PointXYZI> to_pcl(const Frame& f) {
  const RayTable rays(f.intrinsics);
  OrganizedCloud cloud;
  to_organized_cloud(f, rays, cloud);
  pcl::PointCloud<pcl::PointXYZI> out(static_cast<std::uint32_t>(cloud.width), static_cast<std::uint32_t>(cloud.height));
  out.is_dense = false;
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    out.points[i].x = cloud.points[i].x();
    out.points[i].y = cloud.points[i].y();
    out.points[i].z = cloud.points[i].z();
    out.points[i].intensity = f.has_intensity() ? static_cast<float>(f.intensity[i]) : 0.0f;
  }
  return out;
}

/// Plays `dir` once in trigger mode and returns its frames.
std::vector<Expected<Frame>> replay_all(const fs::path& dir, int count) {
  ReplayOptions o;
  o.directory = dir.string();
  o.loop = false;
  ReplayCamera cam(o);
  REQUIRE(cam.open().ok());
  REQUIRE(cam.start().ok());
  std::vector<Expected<Frame>> frames;
  for (int i = 0; i < count; ++i) {
    REQUIRE(cam.software_trigger().ok());
    frames.push_back(cam.grab(milliseconds(2000)));
  }
  return frames;
}

void check_same_frame(const Frame& got, const Frame& want) {
  REQUIRE(got.intrinsics.width == want.intrinsics.width);
  REQUIRE(got.intrinsics.height == want.intrinsics.height);
  CHECK(got.depth_scale_m == 1e-4);
  // Depth in mm becomes exactly ten times the value in 0.1 mm units.
  std::size_t differing = 0;
  for (std::size_t i = 0; i < want.depth.size(); ++i) differing += got.depth[i] != 10 * want.depth[i];
  CHECK(differing == 0);
  // Least squares intrinsics from the points: the original ones to well below a pixel.
  CHECK(got.intrinsics.fx == Approx(want.intrinsics.fx).margin(1e-3));
  CHECK(got.intrinsics.fy == Approx(want.intrinsics.fy).margin(1e-3));
  CHECK(got.intrinsics.cx == Approx(want.intrinsics.cx).margin(1e-3));
  CHECK(got.intrinsics.cy == Approx(want.intrinsics.cy).margin(1e-3));
}

}  // namespace

TEST_CASE("replay: an organized PCD written from a bundled frame plays back as that frame") {
  TempDir dir("pcd");
  auto want = read_frame(kXtion);
  REQUIRE(want.ok());
  REQUIRE(pcl::io::savePCDFileBinary((dir.path() / "cloud.pcd").string(), to_pcl(*want)) == 0);
  auto frames = replay_all(dir.path(), 1);
  INFO(frames[0].error());
  REQUIRE(frames[0].ok());
  const Frame& got = *frames[0];
  check_same_frame(got, *want);
  REQUIRE(got.has_intensity());
  CHECK(got.intensity_bits == 16);
  CHECK(test::same_pixels(got.intensity, want->intensity));  // 8-bit values, carried exactly in 16 bits
  CHECK_FALSE(got.camera_id.empty());

  // The same detection as the frame through plain replay. The depth is the same to the 0.1 mm
  // unit and the intrinsics agree to 1e-3 px, so poses agree to 0.1 mm and 0.01 deg.
  const auto formats = test::recipe_formats(kXtion);
  DetectionParams params;
  Frame through_cloud = got;
  through_cloud.T_base_camera = want->T_base_camera;
  test::require_same_detection(detect(through_cloud, formats, params), detect(*want, formats, params), 1e-4, 0.01);
}

TEST_CASE("replay: an organized PLY plays back - clouds and frames share the name order") {
  TempDir dir("ply");
  auto want = read_frame(kXtion);
  REQUIRE(want.ok());
  pcl::PLYWriter writer;
  REQUIRE(writer.write((dir.path() / "b_cloud.ply").string(), to_pcl(*want), true, false) == 0);
  REQUIRE(write_frame((dir.path() / "a_frame").string(), test::synthetic_frame(64, 48, 3)).ok());
  auto frames = replay_all(dir.path(), 2);
  REQUIRE(frames[0].ok());
  CHECK(frames[0]->intrinsics.width == 64);  // a_frame first
  INFO(frames[1].error());
  REQUIRE(frames[1].ok());
  check_same_frame(*frames[1], *want);
}

TEST_CASE("replay: clouds that are no depth image are errors naming the file - and replay goes on") {
  TempDir dir("badcloud");
  // Unorganized: one row.
  pcl::PointCloud<pcl::PointXYZ> row;
  for (int i = 0; i < 50; ++i) row.push_back(pcl::PointXYZ(0.01f * static_cast<float>(i), 0.0f, 2.0f));
  REQUIRE(pcl::io::savePCDFileASCII((dir.path() / "a_row.pcd").string(), row) == 0);
  // Organized, but the points are shuffled: no pinhole projection fits.
  auto f = read_frame(kXtion);
  REQUIRE(f.ok());
  auto cloud = to_pcl(*f);
  std::swap(cloud.points[200 * 640 + 100], cloud.points[300 * 640 + 500]);
  for (std::size_t i = 0; i + 7 < cloud.points.size(); i += 7) std::swap(cloud.points[i], cloud.points[i + 3]);
  REQUIRE(pcl::io::savePCDFileBinary((dir.path() / "b_shuffled.pcd").string(), cloud) == 0);
  REQUIRE(write_frame((dir.path() / "c_frame").string(), test::synthetic_frame(32, 24, 1)).ok());

  auto frames = replay_all(dir.path(), 3);
  REQUIRE_FALSE(frames[0].ok());
  CHECK(frames[0].error().find("a_row.pcd") != std::string::npos);
  CHECK(frames[0].error().find("not organized") != std::string::npos);
  REQUIRE_FALSE(frames[1].ok());
  CHECK(frames[1].error().find("pinhole") != std::string::npos);
  REQUIRE(frames[2].ok());
  CHECK(frames[2]->intrinsics.width == 32);

  CHECK_FALSE(read_cloud_frame((dir.path() / "missing.pcd").string()).ok());
  CHECK(is_cloud_path("x/y.PLY"));
  CHECK_FALSE(is_cloud_path("x/y.depth.png"));
}
