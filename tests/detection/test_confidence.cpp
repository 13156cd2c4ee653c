// The calibrated confidence (detection/confidence.hpp) on a simulated layer: a plainly right
// layout scores high box by box and as a whole, and weaker evidence scores lower.
#include <algorithm>

#include <catch2/catch.hpp>

#include "palletd/detection/confidence.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/sim/sim.hpp"
#include "sim_block_layer.hpp"

using namespace palletd;

namespace {

/// The shared block layer (sim_block_layer.hpp) rendered by its helios2.
sim::SimulatedFrame block_frame(std::uint64_t seed) {
  return sim::render(testing::block_layer_scene(seed), *sim::profile_by_name("helios2"), seed);
}

Detection detect_frame(const sim::SimulatedFrame& f) {
  std::vector<BoxFormat> formats;
  for (const auto& r : f.scene.recipe) formats.push_back(BoxFormat{r.long_m, r.short_m, r.name, 0.0});
  Detection d = detect(f.frame, formats, DetectionParams{});
  INFO(d.message);
  REQUIRE(d.status == DetectionStatus::kOk);
  REQUIRE(d.boxes.size() == f.truth.boxes.size());
  return d;
}

}  // namespace

TEST_CASE("a plainly right layer scores high, box by box and as a whole", "[confidence]") {
  const Detection d = detect_frame(block_frame(611));
  CHECK_FALSE(d.ambiguous);
  for (const DetectedBox& b : d.boxes) {
    INFO("box " << b.pick_index << " support " << b.score_terms.support << " sigma "
                << b.score_terms.position_sigma_mm);
    CHECK(b.score >= 0.9);
    CHECK(b.score == Approx(box_confidence(b.score_terms)));
    CHECK(b.score_terms.position_sigma_mm > 0.0);
    CHECK(b.score_terms.position_sigma_mm < 5.0);
    CHECK(b.score_terms.pitch_mm > 1.0);
    CHECK(b.score_terms.pitch_mm < 6.0);
    CHECK_FALSE(b.score_terms.contested);
  }
  CHECK(d.layout_confidence >= 0.8);
  CHECK(d.layout_confidence == Approx(layout_confidence(d)));
}

TEST_CASE("weaker evidence gives a lower score", "[confidence]") {
  const Detection d = detect_frame(block_frame(611));
  REQUIRE_FALSE(d.ambiguous);
  const ScoreTerms right = d.boxes.front().score_terms;
  const double base = box_confidence(right);
  INFO("score " << d.boxes.front().score << " base " << base << " sigma " << right.position_sigma_mm
                << " shift " << right.refine_shift_mm << " support " << right.support << " pitch "
                << right.pitch_mm << " contested " << right.contested << " ambiguous "
                << right.layout_ambiguous);

  // A flagged layout (another arrangement ties, or no seam where a slip sheet cannot be ruled
  // out), and then no seam along the box's shared sides either.
  ScoreTerms flagged = right;
  flagged.layout_ambiguous = true;
  CHECK(box_confidence(flagged) < base - 0.05);
  ScoreTerms sheet_like = flagged;
  sheet_like.edge_seams = 0.0;
  sheet_like.support = right.inside * 0.5;
  CHECK(box_confidence(sheet_like) < box_confidence(flagged));

  ScoreTerms loose = right;  // nothing pins its position down
  loose.position_sigma_mm = 40.0;
  CHECK(box_confidence(loose) < 0.7);

  ScoreTerms outside = right;  // a third of it hangs over the outline
  outside.inside = 0.66;
  outside.support = right.support * 0.66;
  CHECK(box_confidence(outside) < base);

  // A flagged layout is less likely exact than the same layout unflagged.
  Detection flagged_layout = d;
  flagged_layout.ambiguous = true;
  CHECK(layout_confidence(flagged_layout) < layout_confidence(d));
  Detection empty = d;
  empty.boxes.clear();
  CHECK(layout_confidence(empty) == 0.0);
}
