// detect() on what a cell shows besides a full layer: the empty pallet, a slip sheet, a stepped
// pallet, and the layer's height above the pallet (simulated scenes, docs/simulator.md).
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/sim/sim.hpp"

using namespace palletd;

namespace {

constexpr double kPalletTop_m = 0.144;  // the simulator's pallets (world = base frame)

sim::SimulatedFrame render_family(sim::SceneFamily family, const std::string& profile_name, std::uint64_t seed,
                                  const std::string& format = "400x300x250", int lower_layers = 1) {
  const sim::SensorProfile profile = *sim::profile_by_name(profile_name);
  sim::ScenarioOptions options;
  options.scene = family;
  options.pattern = sim::PatternFamily::kBlock;
  options.formats = {*sim::parse_format(format)};
  options.lower_layers_min = options.lower_layers_max = lower_layers;
  options.tilt_max_deg = 10.0;
  const Expected<sim::Scene> scene = sim::make_scene(options, profile, seed);
  REQUIRE(scene);
  return sim::render(*scene, profile, seed);
}

std::vector<BoxFormat> formats_of(const sim::SimulatedFrame& f, double height_m = 0.0) {
  std::vector<BoxFormat> out;
  for (const auto& r : f.scene.recipe) out.push_back(BoxFormat{r.long_m, r.short_m, r.name, height_m});
  return out;
}

}  // namespace

TEST_CASE("an empty pallet is empty: by its deck boards, and by the pallet's height", "[cell][empty]") {
  for (const std::uint64_t seed : {3u, 4u}) {
    const sim::SimulatedFrame f = render_family(sim::SceneFamily::kEmpty, "o3d303", seed);
    REQUIRE(f.truth.boxes.empty());
    DetectionParams params;
    const Detection by_boards = detect(f.frame, formats_of(f), params);
    CAPTURE(seed, by_boards.message);
    CHECK(by_boards.status == DetectionStatus::kEmpty);
    CHECK(by_boards.boxes.empty());

    params.pallet.top_z_m = kPalletTop_m;
    const Detection by_height = detect(f.frame, formats_of(f, 0.25), params);
    CAPTURE(by_height.message);
    CHECK(by_height.status == DetectionStatus::kEmpty);
    REQUIRE(by_height.height_above_pallet_m);
    CHECK(std::abs(*by_height.height_above_pallet_m) < 0.02);
    CHECK(by_height.layers_remaining == 0);
  }
}

TEST_CASE("a level below the region of interest leaves it empty, inside it boxes", "[cell][empty]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "o3d303", 7);
  REQUIRE_FALSE(f.truth.boxes.empty());
  DetectionParams params;
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kBase;
  roi.min_m = Eigen::Vector3d(-1.0, -1.0, f.scene.top_z_m + 0.05);  // its floor above the load
  roi.max_m = Eigen::Vector3d(1.0, 1.0, f.scene.top_z_m + 1.0);
  params.roi = roi;
  const Detection above = detect(f.frame, formats_of(f), params);
  CAPTURE(above.message);
  CHECK(above.status == DetectionStatus::kEmpty);
  CHECK(above.boxes.empty());

  roi.min_m.z() = kPalletTop_m - 0.05;
  params.roi = roi;
  const Detection around = detect(f.frame, formats_of(f), params);
  CAPTURE(around.message);
  CHECK(around.status == DetectionStatus::kOk);
  CHECK(around.boxes.size() == f.truth.boxes.size());
}

TEST_CASE("layers left from the pallet's height and the boxes' height", "[cell][height]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "o3d303", 9, "400x300x250", 2);
  DetectionParams params;
  const Detection unknown = detect(f.frame, formats_of(f, 0.25), params);
  REQUIRE(unknown.status == DetectionStatus::kOk);
  CHECK_FALSE(unknown.height_above_pallet_m);
  CHECK_FALSE(unknown.layers_remaining);

  params.pallet.top_z_m = kPalletTop_m;
  const Detection no_heights = detect(f.frame, formats_of(f), params);
  REQUIRE(no_heights.height_above_pallet_m);
  CHECK(*no_heights.height_above_pallet_m == Approx(f.scene.top_z_m - kPalletTop_m).margin(0.01));
  CHECK_FALSE(no_heights.layers_remaining);  // the boxes' height is not configured

  const Detection three = detect(f.frame, formats_of(f, 0.25), params);
  REQUIRE(three.status == DetectionStatus::kOk);
  CHECK(three.layers_remaining == 3);
  CHECK_FALSE(three.height_off_layers);
  CHECK(three.ambiguous == unknown.ambiguous);

  // Boxes said to be 210 mm high: 0.75 m is 3.6 box heights, not a whole number of layers.
  const Detection off = detect(f.frame, formats_of(f, 0.21), params);
  CHECK(off.height_off_layers);
  CHECK(off.ambiguous);
  CHECK(off.ambiguity_reason.find("whole number") != std::string::npos);
}

TEST_CASE("a slip sheet is never an unflagged layout, at a fine pitch it is a slip sheet", "[cell][sheet]") {
  for (const std::uint64_t seed : {5u, 6u}) {
    const sim::SimulatedFrame f = render_family(sim::SceneFamily::kSlipSheet, "helios2", seed);
    REQUIRE(f.truth.expect == "slip_sheet");
    const Detection d = detect(f.frame, formats_of(f), DetectionParams{});
    CAPTURE(seed, to_string(d.status), d.message, d.ambiguity_reason, d.interior_seams.seen_share());
    CHECK_FALSE((d.status == DetectionStatus::kOk && !d.ambiguous));
    CHECK(d.status == DetectionStatus::kSlipSheet);
    CHECK(d.boxes.empty());
  }
}

TEST_CASE("the full layer a sheet would cover shows its seams", "[cell][sheet]") {
  const sim::SimulatedFrame f = render_family(sim::SceneFamily::kIsolated, "helios2", 5);
  const Detection d = detect(f.frame, formats_of(f), DetectionParams{});
  CAPTURE(d.message, d.interior_seams.seen_share());
  REQUIRE(d.status == DetectionStatus::kOk);
  CHECK(d.interior_seams.length_m > 0.0);
  CHECK(d.interior_seams.seen_share() > 0.5);
}

TEST_CASE("a stepped pallet: only the cartons on top", "[cell][stepped]") {
  for (const std::uint64_t seed : {12u, 13u, 14u}) {
    const sim::SimulatedFrame f = render_family(sim::SceneFamily::kStepped, "o3d303", seed);
    REQUIRE_FALSE(f.truth.boxes.empty());
    const Detection d = detect(f.frame, formats_of(f), DetectionParams{});
    CAPTURE(seed, d.message, f.scene.description);
    REQUIRE(d.status == DetectionStatus::kOk);
    CHECK(d.boxes.size() == f.truth.boxes.size());
  }
}
