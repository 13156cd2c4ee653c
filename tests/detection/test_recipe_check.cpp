// The recipe check (detection/recipe_check.hpp): the boxes' measured sides and their tape against
// the recipe's formats, on made-up boxes and on simulated layers detected with the right and a
// wrong recipe;
// formats of one recipe whose cartons look alike (detection/look_alike_formats.hpp).
#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/look_alike_formats.hpp"
#include "palletd/detection/recipe_check.hpp"
#include "palletd/detection/recipe_choice.hpp"
#include "palletd/sim/sim.hpp"

#include "sim_block_layer.hpp"

using namespace palletd;

namespace {

DetectedBox measured_box(int format, double long_m, double short_m) {
  DetectedBox b;
  b.format = format;
  b.measured_long_m = long_m;
  b.measured_short_m = short_m;
  return b;
}

const std::vector<BoxFormat> kFormats = {{0.400, 0.300, "400x300", 0.0}, {0.600, 0.400, "600x400", 0.0}};
constexpr double kPitch_m = 0.003;

/// Detection parameters whose clock never ends a search: the expansion budget does, as when idle.
DetectionParams idle_params() {
  DetectionParams params;
  params.layout.search.time_budget_ms = 1e6;
  return params;
}

/// A layout detected with `formats` that must come out ok and agree with them.
Detection agreeing(const sim::SimulatedFrame& f, const std::vector<BoxFormat>& formats) {
  Detection d = detect(f.frame, formats, idle_params());
  INFO(d.message);
  REQUIRE(d.status == DetectionStatus::kOk);
  CHECK(d.recipe_check.checked);
  CHECK(d.recipe_check.agrees);
  return d;
}

}  // namespace

TEST_CASE("cartons built over their format agree, smaller or far larger ones do not", "[recipe_check]") {
  const RecipeCheckParams params;
  // 4 % over nominal: real cartons.
  RecipeCheck ok = check_recipe({measured_box(0, 0.416, 0.312), measured_box(0, 0.414, 0.311)}, kFormats, params,
                                kPitch_m, 0.06);
  CHECK(ok.checked);
  CHECK(ok.agrees);
  REQUIRE(ok.formats.size() == 2);
  CHECK(ok.formats[0].measured_long_m == Approx(0.415));
  CHECK(ok.formats[0].boxes_long == 2);
  CHECK(ok.formats[1].measured_long_m < 0.0);  // no box of format 1

  // 20 mm smaller than the recipe: another carton.
  RecipeCheck small = check_recipe({measured_box(0, 0.381, 0.300), measured_box(0, 0.379, 0.301)}, kFormats, params,
                                   kPitch_m, 0.06);
  CHECK_FALSE(small.agrees);
  CHECK_FALSE(small.some_agree);
  CHECK(small.reason.find("format 0 (400 x 300 mm) measure 380 x 301 mm") != std::string::npos);

  // 12 % over: no bulge makes that.
  CHECK_FALSE(check_recipe({measured_box(0, 0.448, 0.3), measured_box(0, 0.449, 0.3)}, kFormats, params, kPitch_m, 0.06)
                  .agrees);
}

TEST_CASE("one measured box is no verdict, and a coarse pitch widens the tolerance", "[recipe_check]") {
  const RecipeCheckParams params;
  const RecipeCheck one = check_recipe({measured_box(0, 0.380, 0.280), measured_box(0, -1.0, -1.0)}, kFormats,
                                       params, kPitch_m, 0.06);
  CHECK_FALSE(one.checked);
  CHECK(one.agrees);
  const std::vector<DetectedBox> boxes = {measured_box(0, 0.391, -1.0), measured_box(0, 0.392, -1.0)};
  CHECK_FALSE(check_recipe(boxes, kFormats, params, 0.003, 0.06).agrees);  // 8.5 mm under at 3 mm pixels
  CHECK(check_recipe(boxes, kFormats, params, 0.010, 0.06).agrees);        // within a 10 mm pixel
  RecipeCheckParams off = params;
  off.enabled = false;
  CHECK(check_recipe(boxes, kFormats, off, 0.003, 0.06).agrees);
}

TEST_CASE("rows of pressed boxes bound the size from above: too small disagrees, gaps do not", "[recipe_check]") {
  auto row_box = [](double run_long_m) {
    DetectedBox b = measured_box(0, -1.0, -1.0);
    b.run_long_m = run_long_m;
    return b;
  };
  const RecipeCheck small = check_recipe({row_box(0.382), row_box(0.382)}, kFormats, RecipeCheckParams{}, kPitch_m, 0.06);
  CHECK(small.checked);
  CHECK_FALSE(small.agrees);
  CHECK(small.formats[0].run_long_m == Approx(0.382));
  CHECK(small.reason.find("measure at most 382 x ? mm") != std::string::npos);
  // 60 mm over nominal: gaps the camera did not show count in, so a row never says "larger".
  CHECK(check_recipe({row_box(0.46), row_box(0.46)}, kFormats, RecipeCheckParams{}, kPitch_m, 0.06).agrees);
}

TEST_CASE("a format that fits beside one that does not is a doubtful layout, not another recipe", "[recipe_check]") {
  const RecipeCheck c = check_recipe({measured_box(0, 0.405, 0.303), measured_box(0, 0.404, 0.302),
                                      measured_box(1, 0.560, 0.401), measured_box(1, 0.561, 0.402)},
                                     kFormats, RecipeCheckParams{}, kPitch_m, 0.06);
  CHECK_FALSE(c.agrees);
  CHECK(c.some_agree);
  CHECK(c.formats[0].agrees);
  CHECK_FALSE(c.formats[1].agrees);
  // Boxes laid as 600 x 400 that measure 400 x 300: the other format of the recipe.
  const RecipeCheck swapped = check_recipe({measured_box(1, 0.404, 0.302), measured_box(1, 0.405, 0.301)}, kFormats,
                                           RecipeCheckParams{}, kPitch_m, 0.06);
  CHECK_FALSE(swapped.agrees);
  CHECK(swapped.some_agree);
}

TEST_CASE("boxes taped across their middle are parts of cartons laid the other way", "[recipe_check]") {
  auto taped_box = [](int format, double long_m, double short_m) {
    DetectedBox b = measured_box(format, long_m, short_m);
    b.tape_across = true;
    return b;
  };
  const std::vector<BoxFormat> one = {{0.400, 0.300, "400x300", 0.0}};
  const RecipeCheckParams params;
  // Two boxes whose split side shows nothing, each with a band across: halves of 600 x 400
  // cartons, which the recipe does not hold.
  const RecipeCheck halves =
      check_recipe({taped_box(0, 0.404, -1.0), taped_box(0, 0.405, -1.0), measured_box(0, 0.404, -1.0)}, one,
                   params, kPitch_m, 0.06);
  CHECK(halves.checked);
  CHECK_FALSE(halves.agrees);
  CHECK_FALSE(halves.some_agree);
  CHECK(halves.tape_only);  // their measured long sides agree
  CHECK(halves.formats[0].boxes_tape_across == 2);
  CHECK(halves.reason.find("2 of them carry tape across their middle") != std::string::npos);
  // One such box is no verdict (a print, a label); neither is a box whose four sides were seen.
  CHECK(check_recipe({taped_box(0, 0.404, -1.0), measured_box(0, 0.404, -1.0)}, one, params, kPitch_m, 0.06)
            .agrees);
  CHECK(check_recipe({taped_box(0, 0.404, 0.301), taped_box(0, 0.405, 0.302)}, one, params, kPitch_m, 0.06)
            .agrees);
  RecipeCheckParams off = params;
  off.min_boxes_tape_across = 0;
  CHECK(
      check_recipe({taped_box(0, 0.404, -1.0), taped_box(0, 0.405, -1.0)}, one, off, kPitch_m, 0.06).agrees);
  // With 600 x 400 in the recipe the layout chose the wrong format: flagged, not another recipe.
  const RecipeCheck wrong_format =
      check_recipe({taped_box(0, 0.404, -1.0), taped_box(0, 0.405, -1.0)}, kFormats, params, kPitch_m, 0.06);
  CHECK_FALSE(wrong_format.agrees);
  CHECK(wrong_format.some_agree);
  // Tape across boxes that also measure off: not the tape alone.
  CHECK_FALSE(
      check_recipe({taped_box(0, 0.380, -1.0), taped_box(0, 0.381, -1.0)}, one, params, kPitch_m, 0.06)
          .tape_only);
}

TEST_CASE("boxes taped across each half are two cartons laid the other way", "[recipe_check]") {
  auto in_halves = [](int format, double long_m, double short_m) {
    DetectedBox b = measured_box(format, long_m, short_m);
    b.tape_halves = true;
    return b;
  };
  const std::vector<BoxFormat> twice = {{0.600, 0.400, "600x400", 0.0}};
  const RecipeCheckParams params;
  // Two boxes over pairs of 400 x 300 cartons pressed together: their outer sides measure as the
  // format, the seam between the cartons does not show, and each carton's tape runs across the
  // box along the middle of its half. The sides seen do not make them cartons here.
  const RecipeCheck pairs =
      check_recipe({in_halves(0, 0.606, 0.402), in_halves(0, 0.607, 0.403)}, twice, params, kPitch_m, 0.06);
  CHECK(pairs.checked);
  CHECK_FALSE(pairs.agrees);
  CHECK_FALSE(pairs.some_agree);
  CHECK(pairs.formats[0].boxes_tape_halves == 2);
  CHECK(pairs.reason.find("2 of them carry tape across each half") != std::string::npos);
  // One such box is no verdict; with the key at 0 the tape is not used.
  CHECK(
      check_recipe({in_halves(0, 0.606, 0.402), measured_box(0, 0.607, 0.403)}, twice, params, kPitch_m, 0.06)
          .agrees);
  RecipeCheckParams off = params;
  off.min_boxes_tape_across = 0;
  CHECK(check_recipe({in_halves(0, 0.606, 0.402), in_halves(0, 0.607, 0.403)}, twice, off, kPitch_m, 0.06)
            .agrees);
  // With 400 x 300 in the recipe the layout chose the wrong format: flagged, not another recipe.
  const RecipeCheck wrong_format = check_recipe({in_halves(1, 0.606, 0.402), in_halves(1, 0.607, 0.403)},
                                                kFormats, params, kPitch_m, 0.06);
  CHECK_FALSE(wrong_format.agrees);
  CHECK(wrong_format.some_agree);
}

TEST_CASE(
    "a layer of taped cartons detected as halves of them answers recipe_mismatch and names the right recipe",
    "[recipe_check]") {
  const std::uint64_t seed = 91070;
  const sim::SensorProfile profile = *sim::profile_by_name("helios2");
  sim::ScenarioOptions options = testing::layer_options(sim::PatternFamily::kBlock, "600x400x300");
  options.tape_probability = 1.0;  // every carton closed with tape along its middle
  Expected<sim::Scene> scene = sim::make_scene(options, profile, seed);
  REQUIRE(scene);
  const sim::SimulatedFrame f = sim::render(*scene, profile, seed);
  const std::vector<BoxFormat> right = {{0.600, 0.400, "600x400", 0.0}};
  const std::vector<BoxFormat> half = {{0.400, 0.300, "400x300", 0.0}};  // two of them tile one carton
  const DetectionParams params = idle_params();
  for (const DetectedBox& b : agreeing(f, right).boxes) CHECK_FALSE(b.tape_across);

  const Detection wrong = detect(f.frame, half, params);
  INFO(wrong.message);
  CHECK(wrong.status == DetectionStatus::kRecipeMismatch);
  CHECK(wrong.boxes.empty());
  REQUIRE_FALSE(wrong.recipe_check.formats.empty());
  CHECK(wrong.recipe_check.formats[0].boxes_tape_across >= 2);
  CHECK(wrong.message.find("tape across their middle") != std::string::npos);

  DetectionWorkspace workspace;
  CHECK(best_fitting_recipe(f.frame, {{2, half}, {1, right}}, params, workspace) == 1);
}

TEST_CASE(
    "a layer of taped cartons detected as pairs of them answers recipe_mismatch and names the right recipe",
    "[recipe_check]") {
  const std::uint64_t seed = 91085;
  const sim::SensorProfile profile = *sim::profile_by_name("helios2");
  sim::ScenarioOptions options = testing::layer_options(sim::PatternFamily::kBlock, "400x300x250");
  options.tape_probability = 1.0;  // every carton closed with tape along its middle
  Expected<sim::Scene> scene = sim::make_scene(options, profile, seed);
  REQUIRE(scene);
  const sim::SimulatedFrame f = sim::render(*scene, profile, seed);
  const std::vector<BoxFormat> right = {{0.400, 0.300, "400x300", 0.0}};
  const std::vector<BoxFormat> twice = {{0.600, 0.400, "600x400", 0.0}};  // two cartons side by side
  const DetectionParams params = idle_params();
  for (const DetectedBox& b : agreeing(f, right).boxes) CHECK_FALSE(b.tape_halves);

  const Detection wrong = detect(f.frame, twice, params);
  INFO(wrong.message);
  CHECK(wrong.status == DetectionStatus::kRecipeMismatch);
  CHECK(wrong.boxes.empty());
  REQUIRE_FALSE(wrong.recipe_check.formats.empty());
  CHECK(wrong.recipe_check.formats[0].boxes_tape_halves >= 2);
  CHECK(wrong.message.find("tape across each half") != std::string::npos);
  // Without the tape the pairs pass: their outer sides measure as the format.
  DetectionParams no_tape = params;
  no_tape.recipe_check.min_boxes_tape_across = 0;
  const Detection passed = detect(f.frame, twice, no_tape);
  CHECK(passed.status == DetectionStatus::kOk);
  CHECK_FALSE(passed.ambiguous);

  DetectionWorkspace workspace;
  CHECK(best_fitting_recipe(f.frame, {{1, twice}, {2, right}}, params, workspace) == 2);
}

TEST_CASE("a layer detected with a recipe of larger cartons answers recipe_mismatch and names the right recipe",
          "[recipe_check]") {
  const std::uint64_t seed = 733;
  const sim::SimulatedFrame f = sim::render(testing::block_layer_scene(seed), *sim::profile_by_name("helios2"), seed);
  const std::vector<BoxFormat> right = {{0.400, 0.300, "400x300", 0.0}};
  const std::vector<BoxFormat> larger = {{0.425, 0.315, "425x315", 0.0}};
  const DetectionParams params = idle_params();
  const Detection ok = agreeing(f, right);
  for (const DetectedBox& b : ok.boxes) {
    if (b.measured_long_m > 0.0) CHECK(b.measured_long_m == Approx(0.4).margin(0.02));
  }

  const Detection wrong = detect(f.frame, larger, params);
  INFO(wrong.message);
  CHECK(wrong.status == DetectionStatus::kRecipeMismatch);
  CHECK(is_failure(wrong.status));
  CHECK(wrong.boxes.empty());
  CHECK(wrong.message.find("format 0 (425 x 315 mm)") != std::string::npos);

  DetectionWorkspace workspace;
  // Cartons 50 mm smaller than the layer's fit no layout; a larger format is measured off. (A
  // format two of the layer's cartons make, 600 x 400 here, can tile the same outline: the sides
  // measured cannot tell it, and each carton's tape crosses such a box a quarter of its length
  // from its middle, where tape_across does not look.)
  const std::vector<RecipeCandidate> candidates = {{7, {{0.350, 0.250, "350x250", 0.0}}}, {3, right}, {9, larger}};
  CHECK(best_fitting_recipe(f.frame, candidates, params, workspace) == 3);
  CHECK_FALSE(best_fitting_recipe(f.frame, {{9, larger}}, params, workspace).has_value());
}

TEST_CASE("a layer the recipe cannot lay out answers recipe_mismatch when another recipe lays it out",
          "[recipe_check]") {
  const std::uint64_t seed = 733;
  const sim::SimulatedFrame f =
      sim::render(testing::block_layer_scene(seed), *sim::profile_by_name("helios2"), seed);
  const std::vector<BoxFormat> right = {{0.400, 0.300, "400x300", 0.0}};
  const std::vector<BoxFormat> far_larger = {{0.500, 0.350, "500x350", 0.0}};  // tiles too little of it
  const DetectionParams params = idle_params();
  const Detection failed = detect(f.frame, far_larger, params);
  INFO(failed.message);
  REQUIRE(failed.status == DetectionStatus::kNoLayout);

  DetectionWorkspace workspace;
  Detection named = failed;
  name_recipe_shown(f.frame, {{7, {{0.350, 0.250, "350x250", 0.0}}}, {3, right}}, params, workspace, named);
  CHECK(named.status == DetectionStatus::kRecipeMismatch);
  CHECK(named.recipe_check.best_recipe == 3);
  CHECK(named.boxes.empty());
  CHECK(named.message.find("recipe 3") != std::string::npos);
  // No other recipe lays it out: no_layout it stays, naming none.
  Detection unnamed = failed;
  name_recipe_shown(f.frame, {{9, far_larger}}, params, workspace, unnamed);
  CHECK(unnamed.status == DetectionStatus::kNoLayout);
  CHECK_FALSE(unnamed.recipe_check.best_recipe.has_value());
  // A layout found, or no layer to lay out, is left as it is.
  Detection ok = agreeing(f, right);
  const std::size_t boxes = ok.boxes.size();
  name_recipe_shown(f.frame, {{3, right}}, params, workspace, ok);
  CHECK(ok.status == DetectionStatus::kOk);
  CHECK(ok.boxes.size() == boxes);
  Detection no_layer;
  no_layer.status = DetectionStatus::kNoLayout;
  no_layer.layer.status = DetectionStatus::kNoLayer;
  name_recipe_shown(f.frame, {{3, right}}, params, workspace, no_layer);
  CHECK(no_layer.status == DetectionStatus::kNoLayout);
}

TEST_CASE("formats whose cartons can take the same room on a layer are look-alikes", "[recipe_check]") {
  const std::vector<BoxFormat> formats = {{0.400, 0.300, "400x300", 0.0},
                                          {0.420, 0.320, "420x320", 0.0},
                                          {0.600, 0.400, "600x400", 0.0},
                                          {0.300, 0.200, "300x200", 0.0}};
  // 420 x 320 is a 400 x 300 built 5 % over with a 20 mm gap; 600 x 400 is two 400 x 300, which
  // seams and tape decide, not the cartons' size; 300 x 200 is 100 mm shorter.
  const std::vector<LookAlikeFormats> pairs = look_alike_formats(formats, 0.06, 0.02);
  REQUIRE(pairs.size() == 1);
  CHECK(pairs[0].a == 0);
  CHECK(pairs[0].b == 1);
  CHECK(pairs[0].long_diff_m == Approx(0.020));
  CHECK(pairs[0].short_diff_m == Approx(0.020));
  // Cartons built to their format exactly and standing pressed together: 20 mm apart is two sizes.
  CHECK(look_alike_formats(formats, 0.0, 0.0).empty());
  // One side alike is not enough.
  CHECK(look_alike_formats({{0.400, 0.300, "a", 0.0}, {0.405, 0.200, "b", 0.0}}, 0.06, 0.02).empty());
}
