// Frame files: write -> read round trips, list_frame_stems, truth files.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "palletd/frames/frame_io.hpp"
#include "png_util.hpp"

using namespace palletd;
using palletd::test::make_frame;
using palletd::test::TempDir;

TEST_CASE("frame round trip keeps depth exactly and honours depth_scale") {
  TempDir dir;
  Frame frame = make_frame(40, 30, 0.00025);
  frame.intrinsics.distortion = std::array<double, 5>{0.1, -0.05, 0.001, 0.002, 0.01};
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 0.3, 0.9).normalized()));
  T.translation() = Eigen::Vector3d(0.5, -1.25, 2.0);
  frame.T_base_camera = T;
  const std::string stem = dir.file("f0001");
  REQUIRE(write_frame(stem, frame).ok());

  auto read = read_frame(stem);
  REQUIRE(read.ok());
  const Frame& back = *read;
  CHECK(back.depth == frame.depth);
  CHECK(back.depth_scale_m == 0.00025);
  CHECK(back.intrinsics.width == 40);
  CHECK(back.intrinsics.height == 30);
  CHECK(back.intrinsics.fx == frame.intrinsics.fx);
  CHECK(back.intrinsics.fy == frame.intrinsics.fy);
  CHECK(back.intrinsics.cx == frame.intrinsics.cx);
  CHECK(back.intrinsics.cy == frame.intrinsics.cy);
  CHECK(back.intrinsics.distortion == frame.intrinsics.distortion);
  REQUIRE(back.T_base_camera.has_value());
  CHECK(back.T_base_camera->matrix().isApprox(T.matrix(), 1e-12));
  CHECK(back.camera_id == "test-0001");
  CHECK(back.timestamp_ns == 1234567890123456789LL);
  CHECK_FALSE(back.has_intensity());
  CHECK(back.intensity_bits == 0);

  // Depth in metres comes from depth_scale, not from an assumed millimetre unit.
  const std::size_t i = 5;
  REQUIRE(frame.depth[i] != 0);
  CHECK(back.depth_m(i) == Approx(frame.depth[i] * 0.00025).epsilon(1e-6));
}

TEST_CASE("frame read gives an organized cloud with NaN where depth is 0") {
  TempDir dir;
  const Frame frame = make_frame(16, 12, 0.001);
  const std::string stem = dir.file("cloud");
  REQUIRE(write_frame(stem, frame).ok());
  auto read = read_frame(stem);
  REQUIRE(read.ok());
  const RayTable rays(read->intrinsics);
  OrganizedCloud cloud;
  to_organized_cloud(*read, rays, cloud);
  REQUIRE(cloud.points.size() == frame.pixel_count());
  std::size_t zeros = 0;
  for (std::size_t i = 0; i < frame.depth.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (frame.depth[i] == 0) {
      ++zeros;
      CHECK(std::isnan(p.z()));
    } else {
      CHECK(p.z() == Approx(frame.depth[i] * 0.001).epsilon(1e-6));
    }
  }
  CHECK(zeros > 0);
  // Pixel (u, v) maps through the pinhole model.
  const int u = 4, v = 7;
  const std::size_t idx = static_cast<std::size_t>(v * 16 + u);
  REQUIRE(frame.depth[idx] != 0);
  const double z = frame.depth[idx] * 0.001;
  CHECK(cloud.at(u, v).x() == Approx((u - frame.intrinsics.cx) * z / frame.intrinsics.fx).epsilon(1e-5));
  CHECK(cloud.at(u, v).y() == Approx((v - frame.intrinsics.cy) * z / frame.intrinsics.fy).epsilon(1e-5));
}

TEST_CASE("frame round trip keeps 8-bit and 16-bit intensity") {
  TempDir dir;
  for (const int bits : {8, 16}) {
    Frame frame = make_frame(20, 10, 0.001);
    frame.intensity_bits = bits;
    frame.intensity.resize(frame.pixel_count());
    const unsigned range = bits == 8 ? 256U : 65536U;
    for (std::size_t i = 0; i < frame.intensity.size(); ++i)
      frame.intensity[i] = static_cast<std::uint16_t>((i * 2654435761U) % range);
    const std::string stem = dir.file("i" + std::to_string(bits));
    REQUIRE(write_frame(stem, frame).ok());
    auto back = read_frame(stem);
    REQUIRE(back.ok());
    CHECK(back->intensity_bits == bits);
    CHECK(back->intensity == frame.intensity);
    CHECK(back->depth == frame.depth);
  }
}

TEST_CASE("writing a frame without intensity removes a stale intensity image") {
  TempDir dir;
  Frame frame = make_frame(8, 6, 0.001);
  frame.intensity.assign(frame.pixel_count(), 7);
  frame.intensity_bits = 8;
  const std::string stem = dir.file("s");
  REQUIRE(write_frame(stem, frame).ok());
  REQUIRE(std::filesystem::exists(stem + ".intensity.png"));
  frame.intensity.clear();
  frame.intensity_bits = 0;
  REQUIRE(write_frame(stem, frame).ok());
  CHECK_FALSE(std::filesystem::exists(stem + ".intensity.png"));
  auto back = read_frame(stem);
  REQUIRE(back.ok());
  CHECK_FALSE(back->has_intensity());
}

TEST_CASE("write_frame leaves no temporary files and refuses inconsistent frames") {
  TempDir dir;
  Frame frame = make_frame(8, 6, 0.001);
  REQUIRE(write_frame(dir.file("a"), frame).ok());
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    CHECK(e.path().filename().string().find(".tmp") == std::string::npos);
    ++files;
  }
  CHECK(files == 2);  // a.depth.png, a.json

  frame.depth.pop_back();
  const Status bad_size = write_frame(dir.file("b"), frame);
  CHECK_FALSE(bad_size.ok());
  CHECK_THAT(bad_size.error(), Catch::Contains("b.depth.png"));

  Frame eight = make_frame(8, 6, 0.001);
  eight.intensity.assign(eight.pixel_count(), 300);
  eight.intensity_bits = 8;
  const Status too_bright = write_frame(dir.file("c"), eight);
  CHECK_FALSE(too_bright.ok());
  CHECK_THAT(too_bright.error(), Catch::Contains("above 255"));

  Frame no_scale = make_frame(8, 6, 0.0);
  CHECK_FALSE(write_frame(dir.file("d"), no_scale).ok());
}

TEST_CASE("zero distortion reads as no distortion") {
  TempDir dir;
  Frame frame = make_frame(8, 6, 0.001);
  frame.intrinsics.distortion = std::array<double, 5>{0, 0, 0, 0, 0};
  REQUIRE(write_frame(dir.file("z"), frame).ok());
  auto back = read_frame(dir.file("z"));
  REQUIRE(back.ok());
  CHECK_FALSE(back->intrinsics.distortion.has_value());
}

TEST_CASE("list_frame_stems lists depth images sorted") {
  TempDir dir;
  const Frame frame = make_frame(4, 4, 0.001);
  for (const char* name : {"c", "a", "b10", "b2"}) REQUIRE(write_frame(dir.file(name), frame).ok());
  palletd::test::write_text_file(dir.file("notes.txt"), "x");
  palletd::test::write_text_file(dir.file("x.json"), "{}");
  auto stems = list_frame_stems(dir.path());
  REQUIRE(stems.ok());
  const std::vector<std::string> expected = {dir.file("a"), dir.file("b10"), dir.file("b2"), dir.file("c")};
  CHECK(*stems == expected);

  auto missing = list_frame_stems(dir.file("nope"));
  CHECK_FALSE(missing.ok());
  CHECK_THAT(missing.error(), Catch::Contains("nope"));
}

TEST_CASE("truth file round trip") {
  TempDir dir;
  Truth truth;
  TruthBox a;
  a.center = Eigen::Vector3d(0.1, -0.2, 1.5);
  a.long_axis = Eigen::Vector3d(0.6, 0.8, 0.0);
  a.normal = Eigen::Vector3d(0.0, 0.0, -1.0);
  a.long_m = 0.317;
  a.short_m = 0.231;
  a.format = "F315";
  TruthBox b = a;
  b.center.x() = 0.45;
  b.format = "F600";
  truth.boxes = {a, b};
  truth.layer_plane.normal = Eigen::Vector3d(0.01, 0.0, -1.0).normalized();
  truth.layer_plane.d = 1.5;
  truth.recipe = {"F315", "F600"};
  truth.recipe_mm = {{315, 232}, {600, 400}};
  REQUIRE(write_truth(dir.file("t"), truth).ok());

  auto back = read_truth(dir.file("t"));
  REQUIRE(back.ok());
  REQUIRE(back->boxes.size() == 2);
  CHECK(back->boxes[0].center == a.center);
  CHECK(back->boxes[0].long_axis == a.long_axis);
  CHECK(back->boxes[0].normal == a.normal);
  CHECK(back->boxes[0].long_m == a.long_m);
  CHECK(back->boxes[0].short_m == a.short_m);
  CHECK(back->boxes[1].format == "F600");
  CHECK(back->boxes[1].center.x() == 0.45);
  CHECK(back->layer_plane.normal == truth.layer_plane.normal);
  CHECK(back->layer_plane.d == 1.5);
  CHECK(back->recipe == truth.recipe);
  CHECK(back->recipe_mm == truth.recipe_mm);
}

TEST_CASE("truth file errors name the file and the key") {
  TempDir dir;
  auto missing = read_truth(dir.file("none"));
  CHECK_FALSE(missing.ok());
  CHECK_THAT(missing.error(), Catch::Contains("none.truth.json") && Catch::Contains("not found"));

  palletd::test::write_text_file(dir.file("b.truth.json"),
                                 R"({"boxes": [{"center": [0, 0], "long_axis": [1, 0, 0], "normal": [0, 0, -1],
                                     "size": [0.3, 0.2]}]})");
  auto bad = read_truth(dir.file("b"));
  CHECK_FALSE(bad.ok());
  CHECK_THAT(bad.error(), Catch::Contains("b.truth.json") && Catch::Contains("boxes[0].center"));

  palletd::test::write_text_file(dir.file("c.truth.json"), R"({"layer_plane": [0, 0, 1, 0]})");
  auto no_boxes = read_truth(dir.file("c"));
  CHECK_FALSE(no_boxes.ok());
  CHECK_THAT(no_boxes.error(), Catch::Contains("missing key 'boxes'"));
}
