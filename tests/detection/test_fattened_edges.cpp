// A stereo camera's fattened tops (fattened_edges.hpp): the depth's outline lies outside the
// edges of the infrared image, whose pixels are not matched; stage 5b moves the outline back onto
// them. A time-of-flight camera's depth and amplitude come from one pixel and are left alone.
#include <algorithm>
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/unknown_cartons.hpp"
#include "palletd/sim/sim.hpp"

#include "edge_offset.hpp"
#include "sim_block_layer.hpp"

using namespace palletd;

namespace {

const BoxFormat kNominal{0.400, 0.300, "400x300", 0.0};

sim::SimulatedFrame block_layer(const char* profile, std::uint64_t seed) {
  return testing::render_layer(sim::PatternFamily::kBlock, "400x300x250", profile, seed);
}

DetectionParams untrimmed() {
  DetectionParams p;
  p.layer.fattened_edge_min_px = 0.0;
  return p;
}

/// The largest difference between a side measured on a box and the truth's carton beneath [m].
double worst_side_error_m(const Detection& d, const sim::SimulatedFrame& f) {
  double worst_m = 0.0;
  for (const DetectedBox& b : d.boxes) {
    for (const TruthBox& t : f.truth.boxes) {
      if ((t.center - b.center).norm() > 0.1) continue;
      if (b.measured_long_m > 0.0) worst_m = std::max(worst_m, std::abs(b.measured_long_m - t.long_m));
      if (b.measured_short_m > 0.0) worst_m = std::max(worst_m, std::abs(b.measured_short_m - t.short_m));
    }
  }
  return worst_m;
}

}  // namespace

TEST_CASE("a time-of-flight camera's edges agree in depth and intensity: the outline stays",
          "[fattened_edges]") {
  const sim::SimulatedFrame tof = block_layer("helios2", 21);
  const Detection d = detect(tof.frame, {kNominal}, DetectionParams{});
  REQUIRE(d.status == DetectionStatus::kOk);
  CHECK(std::abs(d.layer.diagnostics.edge_offset_m) < 0.002);
  CHECK(d.layer.diagnostics.edges_moved_in_m == 0.0);
  const Detection raw = detect(tof.frame, {kNominal}, untrimmed());
  CHECK(raw.layer_area_m2 == Approx(d.layer_area_m2));
}

TEST_CASE("a stereo camera's fattened tops are moved back onto the intensity's edges", "[fattened_edges]") {
  const sim::SimulatedFrame stereo = block_layer("d435", 21);
  // As the depth shows it: the matching window fattens the tops by one to two pixels (about
  // 5 mm each at this height), the sides measured that much too long at each end.
  const Detection raw = detect(stereo.frame, {kNominal}, untrimmed());
  REQUIRE(raw.status == DetectionStatus::kOk);
  const EdgeOffset raw_edges = intensity_edge_offset(stereo.frame, raw.layer);
  REQUIRE(raw_edges.samples >= 20);
  CHECK(raw_edges.offset_m > 0.005);
  CHECK(raw_edges.offset_m < 0.015);
  CHECK(raw.layer.diagnostics.edges_moved_in_m == 0.0);
  CHECK(worst_side_error_m(raw, stereo) > 0.008);
  // Moved in: the intensity's edges now lie on the outline and the sides measure the cartons.
  const Detection d = detect(stereo.frame, {kNominal}, DetectionParams{});
  REQUIRE(d.status == DetectionStatus::kOk);
  CHECK(d.layer.diagnostics.edges_moved_in_m == Approx(raw_edges.offset_m));
  CHECK(d.layer.diagnostics.layer_points == raw.layer.diagnostics.layer_points);
  CHECK(d.layer.points_2d.size() < raw.layer.points_2d.size());
  CHECK(std::abs(intensity_edge_offset(stereo.frame, d.layer).offset_m) < 0.5 * raw_edges.offset_m);
  CHECK(d.boxes.size() == stereo.truth.boxes.size());
  CHECK(worst_side_error_m(d, stereo) < 0.006);
  // Without an intensity image there is nothing to compare: the outline stays.
  Frame depth_only = stereo.frame;
  depth_only.intensity.clear();
  CHECK(intensity_edge_offset(depth_only, raw.layer).samples == 0);
  const Detection blind = detect(depth_only, {kNominal}, DetectionParams{});
  CHECK(blind.layer.diagnostics.edges_moved_in_m == 0.0);
}

TEST_CASE("cartons nobody entered on fattened tops: sizes flagged as measured, right once moved in",
          "[fattened_edges][unknown_cartons]") {
  const SizeRange range{0.2, 0.8, 0.15, 0.6};
  const sim::SimulatedFrame stereo = block_layer("d435", 21);
  DetectionWorkspace workspace;
  const Detection raw = detect_unknown_cartons(stereo.frame, range, untrimmed(), workspace);
  REQUIRE(raw.status == DetectionStatus::kOk);
  CHECK(raw.ambiguous);
  CHECK_THAT(raw.ambiguity_reason, Catch::Contains("fattens the tops"));
  UnknownCartonParams lenient;
  lenient.max_edge_offset_px = 1e6;
  const Detection unchecked = detect_unknown_cartons(stereo.frame, range, untrimmed(), workspace, lenient);
  CHECK_THAT(unchecked.ambiguity_reason, !Catch::Contains("fattens the tops"));
  const Detection moved = detect_unknown_cartons(stereo.frame, range, DetectionParams{}, workspace);
  REQUIRE(moved.status == DetectionStatus::kOk);
  CHECK_THAT(moved.ambiguity_reason, !Catch::Contains("fattens the tops"));
  REQUIRE_FALSE(moved.boxes.empty());
  for (const DetectedBox& b : moved.boxes) {
    CHECK(b.long_m == Approx(0.400).margin(0.008));
    CHECK(b.short_m == Approx(0.300).margin(0.008));
  }
}
