// Real cells (issue 19): surroundings and their region of interest, stepped, empty and slip-sheet
// pallets, board decks, oversized boxes, the truth's expect key.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "../../src/sim/sim_internal.hpp"
#include "palletd/frames/frame_io.hpp"
#include "sim_test_util.hpp"

using namespace palletd;
using namespace palletd::sim;

namespace {

/// World point of pixel i of a frame (its depth back-projected and moved to the world).
Eigen::Vector3d world_point(const SimulatedFrame& f, std::size_t i) {
  const Intrinsics& k = f.frame.intrinsics;
  const int u = static_cast<int>(i % static_cast<std::size_t>(k.width));
  const int v = static_cast<int>(i / static_cast<std::size_t>(k.width));
  const double z = f.frame.depth[i] * f.frame.depth_scale_m;
  return f.scene.T_world_camera * Eigen::Vector3d((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
}

/// Pixels whose world point lies over the pallet (inset by `inset_m`) and more than `below_m`
/// under the height `top_z_m`; `over` counts all valid pixels over that area.
std::size_t count_below(const SimulatedFrame& f, double inset_m, double top_z_m, double below_m, std::size_t& over) {
  std::size_t below = 0;
  over = 0;
  for (std::size_t i = 0; i < f.frame.depth.size(); ++i) {
    if (f.frame.depth[i] == 0) continue;
    const Eigen::Vector3d p = world_point(f, i);
    if (std::abs(p.x()) > 0.5 * f.scene.pallet_long_m - inset_m) continue;
    if (std::abs(p.y()) > 0.5 * f.scene.pallet_short_m - inset_m) continue;
    ++over;
    if (p.z() < top_z_m - below_m) ++below;
  }
  return below;
}

/// Renders the scene noise-free from 2 m above its top plane, looking straight down.
SimulatedFrame from_above(Scene scene) {
  scene.T_world_camera = test::look_down(scene.top_z_m + 2.0, 0.0);
  return render(scene, *profile_by_name("blaze101"), 1, test::noise_free());
}

}  // namespace

TEST_CASE("a cell's cabinet stands taller than the load, outside the region of interest") {
  const SensorProfile profile = *profile_by_name("o3d303");
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    ScenarioOptions o;
    o.scene = SceneFamily::kCell;
    o.pallet = seed % 2 == 0 ? PalletKind::kIndustrial1200x1000 : PalletKind::kEur1200x800;
    const Scene scene = *make_scene(o, profile, seed);
    INFO("seed " << seed);
    REQUIRE(scene.has_roi);
    REQUIRE_FALSE(scene.surroundings.empty());
    const SimBox& cabinet = scene.boxes[scene.surroundings.front()];
    CHECK(cabinet.top_z_m >= scene.top_z_m + 0.1 - 1e-9);
    CHECK(cabinet.top_z_m <= scene.top_z_m + 0.5 + 0.25);  // + a layer when the top one is partial
    for (std::size_t idx : scene.surroundings) {
      const SimBox& b = scene.boxes[idx];
      CHECK(b.format_index == -1);
      // No corner inside the region's footprint, and the part does not straddle it.
      double lo_x = 1e9, hi_x = -1e9, lo_y = 1e9, hi_y = -1e9;
      for (const auto& c : detail::footprint_corners(b.center, b.yaw_rad, b.long_m, b.short_m)) {
        lo_x = std::min(lo_x, c.x());
        hi_x = std::max(hi_x, c.x());
        lo_y = std::min(lo_y, c.y());
        hi_y = std::max(hi_y, c.y());
      }
      const bool apart = hi_x <= scene.roi_min_m.x() || lo_x >= scene.roi_max_m.x() || hi_y <= scene.roi_min_m.y() ||
                         lo_y >= scene.roi_max_m.y();
      CHECK(apart);
    }
    // The written region holds the load.
    CHECK(scene.roi_max_m.z() >= scene.top_z_m + 0.3 - 1e-9);
    CHECK(scene.roi_min_m.z() == Approx(0.144 - 0.05));
    const std::string yaml = roi_yaml(scene);
    CHECK(yaml.find("frame: base") != std::string::npos);
    CHECK(yaml.find("min_m: [") != std::string::npos);
    // A calibrated camera, tilted 3-20 deg, the top layer in view and its truth complete.
    const double tilt_deg = std::acos(-scene.T_world_camera.linear().col(2).z()) * 180.0 / 3.14159265358979;
    CHECK(tilt_deg >= 3.0 - 1e-6);
    CHECK(tilt_deg <= 20.0 + 1e-6);
    const Truth truth = make_truth(scene);
    CHECK(truth.boxes.size() == scene.top_layer.size());
    for (const TruthBox& box : truth.boxes)
      for (const Eigen::Vector3d& c : truth_corners(box)) {
        Eigen::Vector2d px;
        REQUIRE(project(profile.intrinsics, c, px));
        CHECK(px.x() >= 0.0);
        CHECK(px.x() <= profile.intrinsics.width - 1.0);
      }
  }
  // Isolated scenes have no surroundings and no region.
  const Scene isolated = *make_scene(ScenarioOptions{}, profile, 1);
  CHECK(isolated.surroundings.empty());
  CHECK(roi_yaml(isolated).empty());
}

TEST_CASE("pallet stops stand beside the pallet, higher than the load, inside the region of interest") {
  const SensorProfile profile = *profile_by_name("helios2");
  std::size_t stops = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    ScenarioOptions o;
    o.scene = seed % 2 == 0 ? SceneFamily::kCell : SceneFamily::kStepped;
    o.pallet_stops = true;
    const Scene scene = *make_scene(o, profile, seed);
    INFO("seed " << seed);
    REQUIRE_FALSE(scene.stops.empty());
    CHECK(scene.stops.size() <= 4);
    stops += scene.stops.size();
    for (const std::size_t idx : scene.stops) {
      const SimBox& b = scene.boxes[idx];
      CHECK(b.format_index == -1);
      CHECK(b.top_z_m >= scene.top_z_m + 0.05 - 1e-9);
      CHECK(b.long_m >= 0.06 - 1e-9);
      CHECK(b.long_m <= 0.10 + 1e-9);
      // Outside the pallet by 20-60 mm on one side, and within its length on the other axis.
      const double out_x = std::abs(b.center.x()) - 0.5 * b.long_m - 0.5 * scene.pallet_long_m;
      const double out_y = std::abs(b.center.y()) - 0.5 * b.long_m - 0.5 * scene.pallet_short_m;
      const double gap = std::max(out_x, out_y);
      CHECK(gap >= 0.02 - 1e-9);
      CHECK(gap <= 0.06 + 1e-9);
      CHECK(std::min(out_x, out_y) < 0.0);
      if (scene.has_roi) {  // its inner face inside the region's footprint
        CHECK(std::abs(b.center.x()) - 0.5 * b.long_m < scene.roi_max_m.x());
        CHECK(std::abs(b.center.y()) - 0.5 * b.long_m < scene.roi_max_m.y());
      }
    }
    // Stops are not part of the truth, and leave the cell's other parts as they were.
    CHECK(make_truth(scene).boxes.size() == scene.top_layer.size());
    o.pallet_stops = false;
    const Scene without = *make_scene(o, profile, seed);
    CHECK(without.boxes.size() + scene.stops.size() == scene.boxes.size());
    CHECK(without.surroundings == scene.surroundings);
  }
  CHECK(stops > 8);  // one to four per scene: more than one on average
}

TEST_CASE("a stepped pallet keeps one to three boxes on a complete level") {
  const SensorProfile profile = *profile_by_name("o3d303");
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    ScenarioOptions o = test::ideal_boxes(PatternFamily::kInterlock);
    o.lower_layers_min = 0;
    o.lower_layers_max = 0;  // a level below is added all the same
    o.scene = SceneFamily::kStepped;
    const Scene scene = *make_scene(o, profile, seed);
    ScenarioOptions full_options = o;
    full_options.scene = SceneFamily::kIsolated;
    const std::size_t full = make_scene(full_options, profile, seed)->top_layer.size();
    std::size_t level = 0;
    for (const SimBox& b : scene.boxes)
      if (b.format_index >= 0 && std::abs(b.top_z_m - (scene.top_z_m - 0.22)) < 1e-6) ++level;
    INFO("seed " << seed);
    CHECK(scene.top_layer.size() >= 1);
    CHECK(scene.top_layer.size() <= 3);
    CHECK(level == full);
    const Truth truth = make_truth(scene);
    CHECK(truth.boxes.size() == scene.top_layer.size());
    CHECK(truth.expect == "boxes");
  }
}

TEST_CASE("an empty pallet has no boxes in its truth and gaps between its deck boards") {
  ScenarioOptions o;
  o.scene = SceneFamily::kEmpty;
  const Scene scene = *make_scene(o, *profile_by_name("o3d303"), 4);
  CHECK(scene.top_layer.empty());
  CHECK(scene.top_z_m == Approx(0.144));
  const Truth truth = make_truth(scene);
  CHECK(truth.expect == "empty");
  CHECK(truth.boxes.empty());
  std::size_t over = 0;
  const std::size_t in_gaps = count_below(from_above(scene), 0.02, 0.144, 0.015, over);
  REQUIRE(over > 1000);
  // Four 41 mm gaps across 800 mm: about a fifth of the deck's area.
  CHECK(static_cast<double>(in_gaps) / static_cast<double>(over) > 0.12);
  CHECK(static_cast<double>(in_gaps) / static_cast<double>(over) < 0.30);
  o.solid_deck = true;  // the old slab shows no gap
  CHECK(count_below(from_above(*make_scene(o, *profile_by_name("o3d303"), 4)), 0.02, 0.144, 0.015, over) == 0);
}

TEST_CASE("pallet decks are boards: five on EUR, seven on 1200x1000, 144 mm high") {
  for (const auto& [kind, boards] : {std::pair<PalletKind, int>{PalletKind::kEur1200x800, 5},
                                     std::pair<PalletKind, int>{PalletKind::kIndustrial1200x1000, 7}}) {
    ScenarioOptions o;
    o.pallet = kind;
    o.scene = SceneFamily::kEmpty;
    const Scene scene = *make_scene(o, *profile_by_name("o3d303"), 1);
    int on_top = 0;
    double highest = 0.0;
    for (const SimBox& b : scene.boxes) {
      highest = std::max(highest, b.top_z_m);
      if (b.top_z_m > 0.1439 && b.long_m == Approx(1.2)) ++on_top;
    }
    CHECK(on_top == boards);
    CHECK(highest == Approx(0.144));
  }
}

TEST_CASE("a slip sheet hides the seams of the level below") {
  ScenarioOptions o;
  o.pattern = PatternFamily::kBrick;
  o.gap_max_m = 0.015;
  o.scene = SceneFamily::kSlipSheet;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const Scene sheet = *make_scene(o, *profile_by_name("o3d303"), seed);
    const Truth truth = make_truth(sheet);
    INFO("seed " << seed);
    CHECK(truth.expect == "slip_sheet");
    CHECK(truth.boxes.empty());
    std::size_t over = 0;
    // Curled strips end at most 50 mm inside the pallet's edge.
    CHECK(count_below(from_above(sheet), 0.06, sheet.top_z_m, 0.001, over) == 0);
    CHECK(over > 1000);
    // Without the sheet the same layer shows its seams.
    ScenarioOptions bare = o;
    bare.scene = SceneFamily::kIsolated;
    const Scene layer = *make_scene(bare, *profile_by_name("o3d303"), seed);
    CHECK(count_below(from_above(layer), 0.06, layer.top_z_m, 0.01, over) > 20);
  }
}

TEST_CASE("oversized boxes: the truth size is the built one, the recipe the nominal one") {
  ScenarioOptions o = test::ideal_boxes(PatternFamily::kBlock);
  o.size_tolerance_m = 0.0;
  o.formats = {*parse_format("400x300")};
  const SensorProfile profile = *profile_by_name("o3d303");
  for (double oversize : {0.0, 0.05}) {
    o.oversize_max = oversize;
    const Truth truth = make_truth(*make_scene(o, profile, 7));
    REQUIRE(truth.recipe_mm.size() == 1);
    CHECK(truth.recipe_mm[0] == std::array<int, 2>{400, 300});
    for (const TruthBox& b : truth.boxes) {
      INFO("oversize " << oversize);
      if (oversize == 0.0) {
        CHECK(b.long_m == Approx(0.4));
      } else {
        CHECK(b.long_m >= 0.4 * 1.0099);
        CHECK(b.long_m <= 0.4 * 1.0501);
        CHECK(b.short_m / b.long_m == Approx(0.75));
      }
    }
  }
}

TEST_CASE("the truth's expect key round-trips through the truth file") {
  const std::string stem = (std::filesystem::path(PALLETD_BINARY_DIR) / "sim_test_expect").string();
  Truth truth;
  truth.expect = "slip_sheet";
  REQUIRE(write_truth(stem, truth).ok());
  auto back = read_truth(stem);
  REQUIRE(back.ok());
  CHECK(back->expect == "slip_sheet");
  CHECK(back->boxes.empty());
  truth.expect = "boxes";  // the default is not written and reads back as boxes
  REQUIRE(write_truth(stem, truth).ok());
  back = read_truth(stem);
  REQUIRE(back.ok());
  CHECK(back->expect == "boxes");
  std::filesystem::remove(stem + ".truth.json");
}
