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
#include "fattened_edges.hpp"
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

/// A block layer of 400x300 cartons seen by a d435 tilted 15-25 deg (the first such scenes from
/// `seed` on): the near sides show their walls, the far ones hide the level behind them.
std::vector<sim::SimulatedFrame> tilted_stereo_layers(std::uint64_t seed, std::size_t count) {
  const sim::SensorProfile p = *sim::profile_by_name("d435");
  sim::ScenarioOptions options = testing::layer_options(sim::PatternFamily::kBlock, "400x300x250");
  options.height_min_m = 1.8;
  options.height_max_m = 2.4;
  options.tilt_max_deg = 25.0;
  std::vector<sim::SimulatedFrame> frames;
  for (; frames.size() < count; ++seed) {
    Expected<sim::Scene> scene = sim::make_scene(options, p, seed);
    REQUIRE(scene);
    const double tilt_deg =
        std::acos(-scene->T_world_camera.linear().col(2).z()) * 180.0 / M_PI;  // optical axis vs down
    if (tilt_deg >= 15.0) frames.push_back(sim::render(*scene, p, seed));
  }
  return frames;
}

/// Summed over the boxes (counted into `boxes`): how far each detected centre lies from its
/// carton's, along the layer away from the camera [m] (positive: beyond the carton).
double summed_shift_away_m(const Detection& d, const sim::SimulatedFrame& f, std::size_t& boxes) {
  double sum_m = 0.0;
  const Eigen::Vector3d n = f.truth.layer_plane.normal.normalized();
  for (const DetectedBox& b : d.boxes) {
    for (const TruthBox& t : f.truth.boxes) {
      if ((t.center - b.center).norm() > 0.1) continue;
      const Eigen::Vector3d away = t.center - n * n.dot(t.center);  // from the camera's foot
      sum_m += (b.center - t.center).dot(away.normalized());
      ++boxes;
    }
  }
  return sum_m;
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
  CHECK(d.layer.diagnostics.edges_moved_in_m == Approx(raw_edges.inset_m));
  CHECK(d.layer.diagnostics.edges_shifted_m == Approx(raw_edges.shift_m.norm()));
  CHECK(raw_edges.inset_m == Approx(raw_edges.offset_m).margin(0.002));
  CHECK(d.layer.diagnostics.layer_points == raw.layer.diagnostics.layer_points);
  CHECK(d.layer.points_2d.size() < raw.layer.points_2d.size());
  CHECK(std::abs(intensity_edge_offset(stereo.frame, d.layer).offset_m) < 0.5 * raw_edges.offset_m);
  CHECK(d.boxes.size() == stereo.truth.boxes.size());
  CHECK(worst_side_error_m(d, stereo) < 0.006);
  // Its time is a stage of its own in the result (metrics: palletd_stage_seconds{stage="edges"}).
  REQUIRE(d.timing_ms.count("edges") == 1);
  CHECK(d.timing_ms.at("edges") > 0.0);
  CHECK(d.timing_ms.at("edges") < d.timing_ms.at("total"));
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

TEST_CASE(
    "a tilted stereo camera fattens the sides that hide the level behind more: the boxes stay where they "
    "stand",
    "[fattened_edges]") {
  double uniform_m = 0.0, facing_m = 0.0;
  std::size_t uniform_boxes = 0, facing_boxes = 0;
  for (const sim::SimulatedFrame& f : tilted_stereo_layers(41, 4)) {
    const Detection raw = detect(f.frame, {kNominal}, untrimmed());
    REQUIRE(raw.status == DetectionStatus::kOk);
    const EdgeOffset edges = intensity_edge_offset(f.frame, raw.layer);
    REQUIRE(edges.samples >= 20);
    // The far sides' tops lie further outside their edges than the near sides': a shift away
    // from the camera, at most half the median offset.
    const Eigen::Vector3d foot = raw.layer.T_camera_layer.inverse() * Eigen::Vector3d::Zero();
    INFO("offset " << edges.offset_m << " inset " << edges.inset_m << " shift " << edges.shift_m.transpose());
    CHECK(edges.shift_m.norm() > 0.001);
    CHECK(edges.shift_m.norm() <= 0.5 * edges.offset_m + 1e-9);
    CHECK(edges.shift_m.dot(-foot.head<2>()) > 0.0);  // from the foot point towards the layer
    // Moving every side in by one offset leaves the centres where the raw outline puts them.
    uniform_m += summed_shift_away_m(raw, f, uniform_boxes);
    const Detection d = detect(f.frame, {kNominal}, DetectionParams{});
    REQUIRE(d.status == DetectionStatus::kOk);
    CHECK(d.layer.diagnostics.edges_shifted_m == Approx(edges.shift_m.norm()));
    facing_m += summed_shift_away_m(d, f, facing_boxes);
  }
  REQUIRE(facing_boxes > 0);
  REQUIRE(uniform_boxes > 0);
  facing_m /= static_cast<double>(facing_boxes);
  uniform_m /= static_cast<double>(uniform_boxes);
  INFO("mean shift away from the camera: one offset " << uniform_m << ", by facing " << facing_m);
  CHECK(uniform_m > 0.003);
  CHECK(std::abs(facing_m) < 0.5 * uniform_m);
}

TEST_CASE(
    "carton top the simplified outline cuts off stays: only the fattened band along the points' edge goes",
    "[fattened_edges]") {
  const sim::SimulatedFrame stereo = block_layer("d435", 21);
  DetectionParams params = untrimmed();
  params.layout.search.time_budget_ms = 1e6;  // the expansion budget alone ends the search (sanitizers)
  const Detection raw = detect(stereo.frame, {kNominal}, params);
  REQUIRE(raw.status == DetectionStatus::kOk);
  REQUIRE(raw.layer.polygons.size() == 1);
  const EdgeOffset edges = intensity_edge_offset(stereo.frame, raw.layer);
  REQUIRE(edges.inset_m > 0.0);
  // An outline that steps 30 mm inside the seen top along one side, as a simplification that
  // takes a seam's notch for the side does.
  LayerResult cut = raw.layer;
  Ring2d& ring = cut.polygons.front().outer;
  REQUIRE(ring.size() >= 4);
  const Eigen::Vector2d a = ring[0], b = ring[1];
  const Eigen::Vector2d along = (b - a).normalized();
  const Eigen::Vector2d in(-along.y(), along.x());  // the outer ring runs counter-clockwise
  const double cut_m = 0.030;
  ring[0] += cut_m * in;
  ring[1] += cut_m * in;
  double area_m2 = 0.0;
  for (const PolygonWithHoles& p : raw.layer.polygons) area_m2 += std::abs(signed_area(p.outer));
  const double pitch_m = std::sqrt(area_m2 / static_cast<double>(raw.layer.points_2d.size()));
  // The points along the middle of that side: within the fattened band, and deeper than the band
  // but beyond the cut.
  const auto count = [&](const LayerResult& layer, double from_m, double to_m) {
    std::size_t n = 0;
    for (const Eigen::Vector2f& q : layer.points_2d) {
      const Eigen::Vector2d rel = q.cast<double>() - a;
      const double t = rel.dot(along) / (b - a).norm(), depth_m = rel.dot(in);
      if (t > 0.2 && t < 0.8 && depth_m > from_m && depth_m < to_m) ++n;
    }
    return n;
  };
  const double band_m = edges.inset_m - edges.shift_m.norm() - 0.5 * pitch_m;
  const double deep_m = edges.inset_m + edges.shift_m.norm() + 2.0 * pitch_m;
  INFO("inset " << edges.inset_m << " shift " << edges.shift_m.norm() << " pitch " << pitch_m);
  REQUIRE(band_m > 0.0);
  REQUIRE(deep_m < cut_m - pitch_m);
  const std::size_t band = count(cut, -1.0, band_m), deep = count(cut, deep_m, cut_m);
  REQUIRE(band > 10);
  REQUIRE(deep > 10);
  const LayerResult trimmed = trim_fattened_edges(stereo.frame, cut, DetectionParams{}.layer);
  // The cut side's own intensity samples move the median offset a little.
  CHECK(trimmed.diagnostics.edges_moved_in_m == Approx(edges.inset_m).margin(0.1 * pitch_m));
  CHECK(count(trimmed, -1.0, band_m) == 0);
  // Kept, but for those beside a hole in the points (a hole is an edge too).
  CHECK(static_cast<double>(count(trimmed, deep_m, cut_m)) >= 0.95 * static_cast<double>(deep));
}
