// Simulated frames on disk: same seed, same bytes; the bundled set in tests/data is consistent.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "palletd/frames/frame_io.hpp"
#include "palletd/sim/sim.hpp"

using namespace palletd;
using namespace palletd::sim;
namespace fs = std::filesystem;

namespace {

std::string bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void write(const SimulatedFrame& f, const std::string& stem) {
  REQUIRE(write_frame(stem, f.frame).ok());
  REQUIRE(write_truth(stem, f.truth).ok());
}

}  // namespace

TEST_CASE("the same seed gives identical files") {
  const fs::path dir = fs::path(PALLETD_BINARY_DIR) / "sim_test_files";
  fs::remove_all(dir);
  fs::create_directories(dir);
  SetOptions set;
  set.count = 2;
  set.seed = 2024;
  set.fill_min = 0.3;
  set.profiles = {"o3d303-small", "o3d303"};  // small frames: the files' bytes are what is compared
  std::vector<SimulatedFrame> rendered;  // run a's frames, to compare with what reads back
  for (const char* run : {"a", "b"}) {
    auto frames = generate_set(set);
    REQUIRE(frames.ok());
    for (const SimulatedFrame& f : *frames) write(f, (dir / (std::string(run) + "_" + f.name)).string());
    if (rendered.empty()) rendered = std::move(*frames);
  }
  std::size_t compared = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("a_", 0) != 0) continue;
    const fs::path twin = dir / ("b_" + name.substr(2));
    REQUIRE(fs::exists(twin));
    CHECK(bytes_of(entry.path()) == bytes_of(twin));
    ++compared;
  }
  CHECK(compared == 2 * 4);  // depth, intensity, json, truth per frame
  // What was written reads back as rendered.
  REQUIRE_FALSE(rendered.empty());
  const SimulatedFrame& f = rendered.front();
  auto frame = read_frame((dir / ("a_" + f.name)).string());
  REQUIRE(frame.ok());
  CHECK(frame->depth == f.frame.depth);
  CHECK(frame->intensity == f.frame.intensity);
  CHECK(frame->depth_scale_m == f.frame.depth_scale_m);
  auto truth = read_truth((dir / ("a_" + f.name)).string());
  REQUIRE(truth.ok());
  REQUIRE(truth->boxes.size() == f.truth.boxes.size());
  CHECK((truth->boxes[0].center - f.truth.boxes[0].center).norm() < 1e-6);
  fs::remove_all(dir);
}

TEST_CASE("the bundled set in tests/data is consistent with its truth") {
  auto stems = list_frame_stems(PALLETD_TEST_DATA_DIR);
  REQUIRE(stems.ok());
  REQUIRE(stems->size() >= 20);
  std::set<std::string> cameras;
  std::set<std::string> formats;
  for (const std::string& stem : *stems) {
    auto frame = read_frame(stem);
    auto truth = read_truth(stem);
    REQUIRE(frame.ok());
    REQUIRE(truth.ok());
    INFO(stem);
    cameras.insert(frame->camera_id);
    const Intrinsics& k = frame->intrinsics;
    REQUIRE_FALSE(truth->boxes.empty());
    std::size_t on_plane = 0, measured = 0;
    for (const TruthBox& box : truth->boxes) {
      formats.insert(box.format);
      Eigen::Vector2d px;
      REQUIRE(project(k, box.center, px));
      CHECK(px.x() >= 0.0);
      CHECK(px.y() >= 0.0);
      CHECK(px.x() <= k.width - 1.0);
      CHECK(px.y() <= k.height - 1.0);
      // The depth at the box centre lies on the layer plane within the noise (or is missing).
      const std::size_t i = static_cast<std::size_t>(std::lround(px.y())) * static_cast<std::size_t>(k.width) +
                            static_cast<std::size_t>(std::lround(px.x()));
      if (frame->depth[i] == 0) continue;
      ++measured;
      const Eigen::Vector3d ray((std::round(px.x()) - k.cx) / k.fx, (std::round(px.y()) - k.cy) / k.fy, 1.0);
      if (std::abs(truth->layer_plane.signed_distance(ray * (frame->depth[i] * frame->depth_scale_m))) < 0.04) ++on_plane;
    }
    CHECK(on_plane >= measured * 9 / 10);
  }
  // Every profile; the bundled set was made before the d435 profile (issue 19) was added.
  CHECK(cameras.size() + 1 >= profile_names().size());
  CHECK(formats.count("315x232") == 1);             // the paper's box
}
