// What a pick does to the layer (sim::simulate_pick): rigid cartons, moved only where they fit.
#include <catch2/catch.hpp>

#include "palletd/sim/pick.hpp"

#include "../../src/sim/sim_internal.hpp"

using namespace palletd;
using namespace palletd::sim;

namespace {

SimBox carton(double x_m, double y_m) {
  SimBox b;
  b.center = Eigen::Vector2d(x_m, y_m);
  b.long_m = 0.4;
  b.short_m = 0.3;
  b.top_z_m = 0.3;
  return b;
}

/// A row of three 400x300 cartons along x, pressed together, and the box to pick beside the
/// middle one (index 3). With `row`: false, the middle carton stands alone beside it.
Scene row_scene(bool row) {
  Scene s;
  s.boxes = {carton(0.0, 0.0), carton(0.0, 0.3)};
  if (row) {
    s.boxes.push_back(carton(-0.4, 0.0));
    s.boxes.push_back(carton(0.4, 0.0));
  }
  for (std::size_t i = 0; i < s.boxes.size(); ++i) s.top_layer.push_back(i);
  return s;
}

}  // namespace

TEST_CASE("a pick takes the box - a missed pick leaves it - a double pick takes the neighbour beside it") {
  Scene clean = row_scene(true);
  PickOutcome c = simulate_pick(clean, 1, PickEvent::kClean, 5);
  CHECK(c.event == PickEvent::kClean);
  CHECK(taken_off(clean.boxes[1]));
  CHECK_FALSE(taken_off(clean.boxes[0]));

  Scene missed = row_scene(true);
  c = simulate_pick(missed, 1, PickEvent::kMissed, 5);
  CHECK(c.gone.empty());
  CHECK_FALSE(taken_off(missed.boxes[1]));

  Scene twice = row_scene(true);
  c = simulate_pick(twice, 1, PickEvent::kDouble, 5);
  CHECK(c.event == PickEvent::kDouble);
  REQUIRE(c.neighbour);
  CHECK(*c.neighbour == 0);  // the one sharing a whole side, not a row end
  CHECK(taken_off(twice.boxes[0]));
  CHECK_FALSE(taken_off(twice.boxes[2]));
}

TEST_CASE("a carton held on both sides by its row is dragged toward the gap - it cannot turn in place") {
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    Scene s = row_scene(true);
    const PickOutcome o = simulate_pick(s, 1, PickEvent::kTurn, seed);
    CHECK(o.event == PickEvent::kDrag);
    CHECK(o.turn_rad == 0.0);
    CHECK(o.shift_m.y() >= 0.005);  // toward the picked box's place
    CHECK(o.shift_m.y() <= 0.040);
    CHECK(std::abs(o.shift_m.x()) < 1e-9);
  }
}

TEST_CASE("a carton with room beside it turns by 2-5 degrees about one end of its side") {
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    Scene s = row_scene(false);
    const PickOutcome o = simulate_pick(s, 1, PickEvent::kTurn, seed);
    CHECK(o.event == PickEvent::kTurn);
    const double turn_deg = std::abs(o.turn_rad) * 180.0 / M_PI;
    CHECK(turn_deg >= 2.0 - 1e-9);
    CHECK(turn_deg <= 5.0 + 1e-9);
    // About an end of the 400 mm side facing the gap: the centre moves by about 0.25 m x turn.
    CHECK(o.shift_m.norm() == Approx(0.25 * std::abs(o.turn_rad)).margin(0.002));
  }
}

TEST_CASE("on built layers a moved neighbour never cuts into another carton") {
  const SensorProfile profile = *profile_by_name("helios2");
  int turned = 0, dragged = 0;
  for (const PatternFamily pattern :
       {PatternFamily::kBlock, PatternFamily::kInterlock, PatternFamily::kBrick, PatternFamily::kPinwheel})
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      ScenarioOptions o;
      o.pattern = pattern;
      const Expected<Scene> built = make_scene(o, profile, seed);
      REQUIRE(built.ok());
      for (const PickEvent event : {PickEvent::kDrag, PickEvent::kTurn}) {
        Scene s = *built;
        const PickOutcome out = simulate_pick(s, s.top_layer.front(), event, seed);
        if (!out.neighbour) continue;
        (out.event == PickEvent::kTurn ? turned : dragged) += 1;
        const SimBox& moved = s.boxes[*out.neighbour];
        for (const std::size_t j : s.top_layer)
          if (j != *out.neighbour && !taken_off(s.boxes[j]))
            CHECK_FALSE(detail::footprints_overlap(moved, s.boxes[j], 2e-4));
        CHECK(out.shift_m.norm() <= 0.045);
      }
    }
  CHECK(turned > 0);
  CHECK(dragged > 0);
}
