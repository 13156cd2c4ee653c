// Carton sizes taught from a detection (results/teach.hpp): grouped sizes, the flags that keep a
// size from being taught, and config entries the config parser reads back.
#include <catch2/catch.hpp>

#include "palletd/config/config.hpp"
#include "palletd/results/teach.hpp"

using namespace palletd;

namespace {

Detection measured_layer(const std::vector<std::pair<double, double>>& sizes_m) {
  Detection d;
  d.status = DetectionStatus::kOk;
  d.formats_measured = true;
  d.boxes.reserve(sizes_m.size());  // built in place: gcc 12 reads a copied optional as uninitialised
  for (const auto& [l, s] : sizes_m) {
    DetectedBox& b = d.boxes.emplace_back();
    b.format = -1;
    b.long_m = l;
    b.short_m = s;
  }
  return d;
}

}  // namespace

TEST_CASE("teaching groups the measured sizes and writes entries the config reads back", "[teach]") {
  const Detection d =
      measured_layer({{0.4012, 0.2991}, {0.3996, 0.3004}, {0.4021, 0.3010}, {0.6003, 0.3998}});
  const Teaching t = teach_from(d);
  CHECK(t.taught);
  REQUIRE(t.formats.size() == 2);
  CHECK(t.formats[0].boxes == 3);  // the commonest size first
  CHECK(t.formats[0].long_mm == 401);
  CHECK(t.formats[0].short_mm == 300);
  CHECK(t.formats[0].spread_mm == Approx(0.9).margin(0.05));
  CHECK(t.formats[1].long_mm == 600);

  const std::string yaml = recipe_yaml(t, 12, "supplier X");
  const Config c = parse_config(yaml + "pipeline:\n  default_recipe: 12\n", "taught.yaml");
  REQUIRE(c.formats.size() == 2);
  CHECK(c.formats[0].name == "401x300");
  CHECK(c.formats[0].long_m == Approx(0.401));
  REQUIRE(c.recipes.size() == 1);
  CHECK(c.recipes[0].number == 12);
  CHECK(c.recipes[0].name == "supplier X");
  CHECK(c.recipes[0].formats == std::vector<int>{0, 1});
}

TEST_CASE("a flagged layout or a failed frame teaches nothing for sure", "[teach]") {
  Detection flagged = measured_layer({{0.4, 0.3}, {0.4, 0.3}});
  flagged.ambiguous = true;
  flagged.ambiguity_reason = "one carton cannot be told from two";
  const Teaching t = teach_from(flagged);
  CHECK_FALSE(t.taught);
  CHECK_THAT(t.reason, Catch::Contains("one carton cannot be told from two"));
  CHECK(t.formats.size() == 1);  // still shown, to check by hand

  Detection failed;
  failed.status = DetectionStatus::kNoLayer;
  failed.message = "nothing above the floor";
  const Teaching none = teach_from(failed);
  CHECK_FALSE(none.taught);
  CHECK(none.formats.empty());
  CHECK_THAT(none.reason, Catch::Contains("no_layer"));
}
