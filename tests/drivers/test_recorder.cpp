// The frame recorder: same format as replay, ring size limit, no half frames.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "drivers_test_util.hpp"
#include "palletd/drivers/camera.hpp"
#include "palletd/config/config.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/frames/recorder.hpp"

using namespace palletd;
using palletd::test::synthetic_frame;
using palletd::test::TempDir;

namespace {

std::uint64_t folder_bytes(const std::filesystem::path& dir) {
  std::uint64_t total = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.is_regular_file()) total += e.file_size();
  }
  return total;
}

}  // namespace

TEST_CASE("recorded frames replay byte-identical, with detection JSON and overlay beside them") {
  TempDir dir("rec");
  FrameRecorder rec(RecorderOptions{dir.str(), 1ull << 30});
  std::vector<Frame> frames;
  for (std::uint32_t i = 0; i < 3; ++i) {
    frames.push_back(synthetic_frame(40, 30, i + 10));
    frames.back().sequence = i;
    const std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', static_cast<std::uint8_t>(i)};
    auto stem = rec.record(frames.back(), "{\"status\":\"ok\"}", png);
    REQUIRE(stem.ok());
    CHECK(std::filesystem::exists(stem.value() + ".depth.png"));
    CHECK(std::filesystem::exists(stem.value() + ".json"));
    CHECK(std::filesystem::exists(stem.value() + ".detection.json"));
    CHECK(std::filesystem::file_size(stem.value() + ".overlay.png") == png.size());
  }
  CHECK(rec.recordings() == 3);
  CHECK(std::filesystem::is_empty(dir.path() / ".partial"));

  CameraConfig c;
  c.driver = "replay";
  c.replay.directory = dir.str();
  c.replay.loop = false;
  auto cam = make_camera(c);
  REQUIRE(cam->open().ok());
  REQUIRE(cam->start().ok());
  for (const auto& f : frames) {
    REQUIRE(cam->software_trigger().ok());
    auto got = cam->grab(std::chrono::milliseconds(200));
    REQUIRE(got.ok());
    CHECK(got->depth == f.depth);
    CHECK(got->depth_scale_m == f.depth_scale_m);
    CHECK(got->intrinsics.fx == Approx(f.intrinsics.fx));
  }
}

TEST_CASE("the recorder keeps the folder under its size limit, deleting the oldest first") {
  TempDir dir("ring");
  // Measure one recording, then allow about three.
  std::uint64_t one = 0;
  {
    TempDir probe("ring-probe");
    FrameRecorder p(RecorderOptions{probe.str(), 1ull << 30});
    REQUIRE(p.record(synthetic_frame(40, 30, 1)).ok());
    one = p.bytes_on_disk();
  }
  REQUIRE(one > 0);
  FrameRecorder rec(RecorderOptions{dir.str(), one * 3 + one / 2});
  std::vector<std::string> stems;
  for (std::uint32_t i = 0; i < 8; ++i) {
    Frame f = synthetic_frame(40, 30, 1);  // same content, same size
    f.sequence = i;
    auto stem = rec.record(f);
    REQUIRE(stem.ok());
    stems.push_back(stem.value());
    CHECK(rec.bytes_on_disk() <= one * 3 + one / 2);
    CHECK(folder_bytes(dir.path()) == rec.bytes_on_disk());
  }
  CHECK(rec.recordings() == 3);
  CHECK_FALSE(std::filesystem::exists(stems[0] + ".depth.png"));
  CHECK_FALSE(std::filesystem::exists(stems[4] + ".json"));
  CHECK(std::filesystem::exists(stems[5] + ".depth.png"));
  CHECK(std::filesystem::exists(stems[7] + ".depth.png"));
  auto listed = list_frame_stems(dir.str());
  REQUIRE(listed.ok());
  REQUIRE(listed->size() == 3);
  CHECK(listed->front() == stems[5]);  // name order is recording order
}

TEST_CASE("a recorder restarted after a power cut drops partial frames and counts old ones") {
  TempDir dir("cut");
  {
    FrameRecorder rec(RecorderOptions{dir.str(), 1ull << 30});
    REQUIRE(rec.record(synthetic_frame(20, 10, 4)).ok());
    REQUIRE(rec.record(synthetic_frame(20, 10, 5)).ok());
  }
  // What a cut leaves: a half-written file in .partial, and a frame whose JSON was renamed
  // in but whose depth PNG (renamed last) never arrived.
  { std::ofstream(dir.path() / ".partial" / "x.depth.png") << "half"; }
  { std::ofstream(dir.path() / "29990101T000000000Z-000001.json") << "{}"; }
  FrameRecorder again(RecorderOptions{dir.str(), 1ull << 30});
  REQUIRE(again.scan().ok());
  CHECK(again.recordings() == 2);
  CHECK(std::filesystem::is_empty(dir.path() / ".partial"));
  CHECK_FALSE(std::filesystem::exists(dir.path() / "29990101T000000000Z-000001.json"));
  CHECK(folder_bytes(dir.path()) == again.bytes_on_disk());
  auto listed = list_frame_stems(dir.str());
  REQUIRE(listed.ok());
  for (const auto& stem : *listed) CHECK(read_frame(stem).ok());
}
