// Frame files: every kind of bad input is a clear error naming the file and the problem.
#include <catch2/catch.hpp>

#include <filesystem>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "palletd/frames/frame_io.hpp"
#include "png_util.hpp"

using namespace palletd;
using palletd::test::TempDir;
using Catch::Contains;

namespace {

/// A valid 12x10 frame on disk; tests then break one thing.
std::string good_frame(const TempDir& dir, const std::string& name = "f", bool intensity = false) {
  Frame frame = palletd::test::make_frame(12, 10, 0.001);
  if (intensity) {
    frame.intensity.assign(frame.pixel_count(), 100);
    frame.intensity_bits = 8;
  }
  const std::string stem = dir.file(name);
  REQUIRE(write_frame(stem, frame).ok());
  REQUIRE(read_frame(stem).ok());
  return stem;
}

/// Edits STEM.json through a function on its JSON object.
template <typename F>
void edit_json(const std::string& stem, F&& edit) {
  nlohmann::json j = nlohmann::json::parse(palletd::test::read_whole_file(stem + ".json"));
  edit(j);
  palletd::test::write_text_file(stem + ".json", j.dump());
}

std::string error_of(const std::string& stem) {
  auto r = read_frame(stem);
  REQUIRE_FALSE(r.ok());
  return r.error();
}

}  // namespace

TEST_CASE("missing frame files are named") {
  TempDir dir;
  const std::string stem = good_frame(dir);
  std::filesystem::remove(stem + ".depth.png");
  CHECK_THAT(error_of(stem), Contains("f.depth.png") && Contains("not found"));

  const std::string stem2 = good_frame(dir, "g");
  std::filesystem::remove(stem2 + ".json");
  CHECK_THAT(error_of(stem2), Contains("g.json") && Contains("not found"));

  CHECK_THAT(error_of(dir.file("nothing")), Contains("nothing.json"));
}

TEST_CASE("an 8-bit depth PNG is refused") {
  TempDir dir;
  const std::string stem = good_frame(dir);
  palletd::test::write_png_file(stem + ".depth.png", cv::Mat(10, 12, CV_8UC1, cv::Scalar(50)));
  CHECK_THAT(error_of(stem), Contains("f.depth.png") && Contains("16-bit") && Contains("8-bit"));
}

TEST_CASE("a colour depth PNG is refused") {
  TempDir dir;
  const std::string stem = good_frame(dir);
  palletd::test::write_png_file(stem + ".depth.png", cv::Mat(10, 12, CV_16UC3, cv::Scalar(1000, 1000, 1000)));
  CHECK_THAT(error_of(stem), Contains("f.depth.png") && Contains("single-channel"));
}

TEST_CASE("depth size must match width and height in the json") {
  TempDir dir;
  const std::string stem = good_frame(dir);
  palletd::test::write_png_file(stem + ".depth.png", cv::Mat(10, 13, CV_16UC1, cv::Scalar(1000)));
  CHECK_THAT(error_of(stem), Contains("f.depth.png") && Contains("13x10") && Contains("12x10"));
}

TEST_CASE("intensity size must match the depth image") {
  TempDir dir;
  const std::string stem = good_frame(dir, "f", true);
  palletd::test::write_png_file(stem + ".intensity.png", cv::Mat(9, 12, CV_8UC1, cv::Scalar(7)));
  CHECK_THAT(error_of(stem), Contains("f.intensity.png") && Contains("12x9") && Contains("does not match"));
}

TEST_CASE("a colour intensity PNG is refused") {
  TempDir dir;
  const std::string stem = good_frame(dir, "f", true);
  palletd::test::write_png_file(stem + ".intensity.png", cv::Mat(10, 12, CV_8UC3, cv::Scalar(1, 2, 3)));
  CHECK_THAT(error_of(stem), Contains("f.intensity.png") && Contains("single-channel"));
}

TEST_CASE("missing json keys are named") {
  TempDir dir;
  for (const char* key : {"width", "height", "fx", "fy", "cx", "cy", "depth_scale"}) {
    const std::string stem = good_frame(dir, std::string("m_") + key);
    edit_json(stem, [&](nlohmann::json& j) { j.erase(key); });
    CHECK_THAT(error_of(stem), Contains(".json") && Contains(std::string("missing key '") + key + "'"));
  }
}

TEST_CASE("wrong-typed json keys are named") {
  TempDir dir;
  const std::string s1 = good_frame(dir, "a");
  edit_json(s1, [](nlohmann::json& j) { j["fx"] = "475"; });
  CHECK_THAT(error_of(s1), Contains("a.json") && Contains("'fx' must be a number"));

  const std::string s2 = good_frame(dir, "b");
  edit_json(s2, [](nlohmann::json& j) { j["width"] = 12.5; });
  CHECK_THAT(error_of(s2), Contains("b.json") && Contains("'width' must be an integer"));

  const std::string s3 = good_frame(dir, "c");
  edit_json(s3, [](nlohmann::json& j) { j["camera"] = 5; });
  CHECK_THAT(error_of(s3), Contains("c.json") && Contains("'camera' must be a string"));

  const std::string s4 = good_frame(dir, "d");
  edit_json(s4, [](nlohmann::json& j) { j["timestamp_ns"] = "now"; });
  CHECK_THAT(error_of(s4), Contains("d.json") && Contains("'timestamp_ns' must be an integer"));

  const std::string s5 = good_frame(dir, "e");
  palletd::test::write_text_file(s5 + ".json", "{\"width\": 12, ");
  CHECK_THAT(error_of(s5), Contains("e.json") && Contains("not valid JSON"));

  const std::string s6 = good_frame(dir, "g");
  palletd::test::write_text_file(s6 + ".json", "[1, 2]");
  CHECK_THAT(error_of(s6), Contains("g.json") && Contains("JSON object"));
}

TEST_CASE("unknown json keys are ignored") {
  TempDir dir;
  const std::string stem = good_frame(dir);
  edit_json(stem, [](nlohmann::json& j) { j["exposure_us"] = 1200; j["vendor"] = {{"x", 1}}; });
  CHECK(read_frame(stem).ok());
}

TEST_CASE("non-positive focal length or depth_scale is refused") {
  TempDir dir;
  const std::vector<std::pair<const char*, double>> cases = {
      {"fx", 0.0}, {"fy", -475.0}, {"depth_scale", 0.0}, {"depth_scale", -0.001}};
  int n = 0;
  for (const auto& [key, value] : cases) {
    const std::string stem = good_frame(dir, "n" + std::to_string(n++));
    edit_json(stem, [&, k = key, v = value](nlohmann::json& j) { j[k] = v; });
    CHECK_THAT(error_of(stem), Contains(".json") && Contains(std::string("'") + key + "'") && Contains("positive"));
  }
  const std::string stem = good_frame(dir, "w");
  edit_json(stem, [](nlohmann::json& j) { j["height"] = 0; });
  CHECK_THAT(error_of(stem), Contains("'height' must be positive"));
}

TEST_CASE("truncated PNGs are errors, not crashes") {
  TempDir dir;
  const std::string stem = good_frame(dir);
  const std::string full = palletd::test::read_whole_file(stem + ".depth.png");
  REQUIRE(full.size() > 60);
  // Cut inside the signature, inside the header, inside the image data and just before IEND.
  for (const std::size_t keep : {std::size_t{4}, std::size_t{20}, full.size() / 2, full.size() - 12}) {
    palletd::test::write_text_file(stem + ".depth.png", full);
    palletd::test::truncate_file(stem + ".depth.png", keep);
    INFO("kept " << keep << " of " << full.size() << " bytes");
    const std::string e = error_of(stem);
    CHECK_THAT(e, Contains("f.depth.png"));
    CHECK_THAT(e, Contains("PNG"));
  }
  palletd::test::truncate_file(stem + ".depth.png", 0);
  CHECK_THAT(error_of(stem), Contains("not a PNG"));

  const std::string stem2 = good_frame(dir, "i", true);
  const auto size = std::filesystem::file_size(stem2 + ".intensity.png");
  palletd::test::truncate_file(stem2 + ".intensity.png", size / 2);
  CHECK_THAT(error_of(stem2), Contains("i.intensity.png") && Contains("truncated"));
}

TEST_CASE("bad distortion and camera_to_base arrays are refused") {
  TempDir dir;
  const std::string s1 = good_frame(dir, "d1");
  edit_json(s1, [](nlohmann::json& j) { j["distortion"] = {0.1, 0.0, 0.0, 0.0}; });
  CHECK_THAT(error_of(s1), Contains("d1.json") && Contains("'distortion'") && Contains("5 numbers"));

  const std::string s2 = good_frame(dir, "d2");
  edit_json(s2, [](nlohmann::json& j) { j["distortion"] = {0.1, 0.0, "x", 0.0, 0.0}; });
  CHECK_THAT(error_of(s2), Contains("'distortion'"));

  const std::string s3 = good_frame(dir, "t1");
  edit_json(s3, [](nlohmann::json& j) { j["camera_to_base"] = std::vector<double>(15, 0.0); });
  CHECK_THAT(error_of(s3), Contains("t1.json") && Contains("'camera_to_base'") && Contains("16 numbers"));

  const std::string s4 = good_frame(dir, "t2");
  edit_json(s4, [](nlohmann::json& j) {
    j["camera_to_base"] = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // scaled, not rigid
  });
  CHECK_THAT(error_of(s4), Contains("t2.json") && Contains("rigid"));

  const std::string s5 = good_frame(dir, "t3");
  edit_json(s5, [](nlohmann::json& j) {
    j["camera_to_base"] = {1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 2.0, 0, 0, 0, 1};
  });
  auto ok = read_frame(s5);
  REQUIRE(ok.ok());
  CHECK(ok->T_base_camera->translation() == Eigen::Vector3d(0.5, 0.0, 2.0));
  CHECK(ok->T_base_camera->rotation().isApprox(Eigen::Matrix3d::Identity()));
}
