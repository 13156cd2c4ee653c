// Cartons nobody entered (detection/unknown_cartons.hpp): carton sizes proposed by the layer's
// outline and seams, and the whole detection with a size range instead of formats, on simulated
// layers of a time-of-flight camera and of a stereo camera that hides the seams.
#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/unknown_cartons.hpp"
#include "palletd/sim/sim.hpp"

#include "sim_block_layer.hpp"

using namespace palletd;
using palletd::testing::render_layer;

namespace {

const SizeRange kRange{0.2, 0.8, 0.15, 0.6};

}  // namespace

TEST_CASE("the seams and the outline of a block layer propose its carton's size", "[unknown_cartons]") {
  // Gaps of 5-15 mm on a time-of-flight camera: the seams show.
  const sim::SimulatedFrame f = render_layer(sim::PatternFamily::kBlock, "400x300x250", "helios2", 733, 0.015);
  const Detection known = detect(f.frame, {{0.400, 0.300, "400x300", 0.0}}, DetectionParams{});
  REQUIRE(known.status == DetectionStatus::kOk);
  OrganizedCloud cloud;
  RayTable rays(f.frame.intrinsics);
  to_organized_cloud(f.frame, rays, cloud);
  const SeamEvidence seams = build_seam_evidence(f.frame, cloud, known.layer);
  const std::vector<SizeCandidate> sizes = candidate_sizes(known.layer, seams, kRange, UnknownCartonParams{});
  REQUIRE_FALSE(sizes.empty());
  CHECK(sizes.size() <= static_cast<std::size_t>(UnknownCartonParams{}.max_candidates));
  const bool proposed = std::any_of(sizes.begin(), sizes.end(), [](const SizeCandidate& c) {
    return std::abs(c.format.long_m - 0.4) < 0.012 && std::abs(c.format.short_m - 0.3) < 0.012;
  });
  CHECK(proposed);
  for (const SizeCandidate& c : sizes) CHECK(kRange.admits(c.format.long_m, c.format.short_m));
  // A range that admits no carton of the layer proposes nothing.
  CHECK(candidate_sizes(known.layer, seams, SizeRange{0.9, 1.0, 0.85, 0.9}, UnknownCartonParams{}).empty());
}

TEST_CASE("a layer of cartons nobody entered: boxes with format -1 and the size measured",
          "[unknown_cartons]") {
  // Gaps of up to 15 mm seen by a time-of-flight camera: the seams show.
  const sim::SimulatedFrame f = render_layer(sim::PatternFamily::kBlock, "400x300x250", "helios2", 733, 0.015);
  DetectionWorkspace workspace;
  const Detection d = detect_unknown_cartons(f.frame, kRange, DetectionParams{}, workspace);
  INFO(d.message << " " << d.ambiguity_reason);
  REQUIRE(d.status == DetectionStatus::kOk);
  CHECK(d.formats_measured);
  CHECK_FALSE(d.ambiguous);
  CHECK(d.boxes.size() == f.truth.boxes.size());
  for (const DetectedBox& b : d.boxes) {
    CHECK(b.format == -1);
    CHECK(b.long_m == Approx(0.400).margin(0.006));
    CHECK(b.short_m == Approx(0.300).margin(0.006));
  }
  // Every carton's centre within 15 mm of a detected box's.
  for (const TruthBox& t : f.truth.boxes) {
    double nearest_m = 1e9;
    for (const DetectedBox& b : d.boxes) nearest_m = std::min(nearest_m, (b.center - t.center).norm());
    CHECK(nearest_m < 0.015);
  }
  // The same frame where the seams had to show on every box to tell the size: flagged, and the
  // confidence drops with it.
  UnknownCartonParams strict;
  strict.min_evidence = 1.01;
  const Detection doubted = detect_unknown_cartons(f.frame, kRange, DetectionParams{}, workspace, strict);
  REQUIRE(doubted.status == DetectionStatus::kOk);
  CHECK(doubted.ambiguous);
  CHECK_THAT(doubted.ambiguity_reason, Catch::Contains("one carton cannot be told from two"));
  CHECK(doubted.layout_confidence < d.layout_confidence);
}

TEST_CASE("on a stereo camera that smooths the seams the layout is right or flagged, never silently wrong",
          "[unknown_cartons]") {
  for (const std::uint64_t seed : {17, 18}) {
    const sim::SimulatedFrame f = render_layer(sim::PatternFamily::kBlock, "400x300x250", "d435", seed);
    DetectionWorkspace workspace;
    const Detection d = detect_unknown_cartons(f.frame, kRange, DetectionParams{}, workspace);
    INFO("seed " << seed << ": " << d.message << " " << d.ambiguity_reason);
    if (d.status != DetectionStatus::kOk) {
      CHECK(d.boxes.empty());
      continue;
    }
    if (d.ambiguous) {
      CHECK_FALSE(d.ambiguity_reason.empty());
      continue;
    }
    CHECK(d.boxes.size() == f.truth.boxes.size());
    for (const TruthBox& t : f.truth.boxes) {
      double nearest_m = 1e9;
      for (const DetectedBox& b : d.boxes) nearest_m = std::min(nearest_m, (b.center - t.center).norm());
      CHECK(nearest_m < 0.015);
    }
  }
}

TEST_CASE("an empty size range is a clear error, not a layout", "[unknown_cartons]") {
  const sim::SimulatedFrame f = render_layer(sim::PatternFamily::kBlock, "400x300x250", "helios2", 5);
  DetectionWorkspace workspace;
  const Detection d =
      detect_unknown_cartons(f.frame, SizeRange{0.5, 0.4, 0.2, 0.3}, DetectionParams{}, workspace);
  CHECK(d.status == DetectionStatus::kNoLayout);
  CHECK(d.boxes.empty());
  CHECK_THAT(d.message, Catch::Contains("size_range_mm"));
}
