// Recipes over Modbus end to end: an unknown recipe number, a layer of other cartons than the
// recipe's (the recipe that fits named in 532), size-range recipes (measured sizes in 910 + 2 i).
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include <catch2/catch.hpp>

#include "palletd/config/config.hpp"
#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/service/service.hpp"

#include "service_fixtures.hpp"

using namespace std::chrono_literals;
using palletd::modbus::ErrorCode;
using palletd::modbus::ResultStatus;
using namespace palletd::service_test;

namespace {

/// The configured recipe of that number (register 532's value), null when none is.
const palletd::Recipe* recipe_numbered(const palletd::Config& config, int number) {
  for (const auto& r : config.recipes)
    if (r.number == number) return &r;
  return nullptr;
}

bool lists_format(const palletd::Config& config, const palletd::Recipe& recipe, const std::string& name) {
  return std::any_of(recipe.formats.begin(), recipe.formats.end(),
                     [&](int f) { return config.formats[static_cast<std::size_t>(f)].name == name; });
}

}  // namespace

TEST_CASE("an unknown recipe fails the trigger with error code 5 and its number as detail") {
  TempFrames frames(bundled_stems(1));
  palletd::Service service(demo_config(frames.dir));
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  auto result = plc.trigger(999, 7, 10s);
  REQUIRE(result.ok());
  CHECK(result->result.record.status == ResultStatus::kFailed);
  CHECK(result->status.error == ErrorCode::kUnknownRecipe);
  CHECK(result->status.error_detail == 999);
  CHECK((result->status.status_word & palletd::modbus::kStError) != 0);
}

// palletctl simulate --out s400 -n 60 --pattern block interlock brick pinwheel chimney --profile all
// --format 400x300x250 --oversize-max 0.03 --corner-radius 3:8 --gap-max 20 --seed 90601, frame 17
// (helios2): eight cartons of 400 x 300 whose sides the camera shows, measured 404 x 303 against
// a recipe of 420 x 315.
TEST_CASE("a layer of other cartons fails with detail 8 and names the configured recipe that fits") {
  TempFrames frames({"recipe/block_400x300_smaller_than_420x315_helios2"});
  palletd::Config config = demo_config(frames.dir);
  config.formats.push_back(palletd::BoxFormat{0.420, 0.315, "420x315", 0.0});
  // Two candidates to name (a detection each) and room for them under the sanitizers.
  config.recipes.resize(2);
  config.recipes.push_back({20, "420x315", {static_cast<int>(config.formats.size()) - 1}, std::nullopt});
  config.pipeline.detection_timeout_ms = 120000.0;
  // The search must end on its expansion budget, as on an idle machine, not on the 200 ms wall
  // clock a sanitizer build runs ten times slower against: cut short, the layout it returns may
  // measure no side, and the recipe check has nothing to judge.
  config.detection.layout.search.time_budget_ms = 5000.0;
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  auto result = plc.trigger(20, 8, 120s);
  REQUIRE(result.ok());
  const palletd::modbus::ResultRecord& rec = result->result.record;
  CHECK(rec.status == ResultStatus::kFailed);
  CHECK(rec.boxes.empty());
  CHECK(result->status.error == ErrorCode::kDetectionFailed);
  CHECK(result->status.error_detail ==
        static_cast<std::uint16_t>(palletd::modbus::DetectionFailure::kRecipeMismatch));
  // The recipe named lists the frame's 400 x 300 cartons.
  const palletd::Recipe* named = recipe_numbered(config, rec.best_recipe);
  REQUIRE(named != nullptr);
  CHECK(lists_format(config, *named, "400x300"));
  // The right recipe on the same frame answers with boxes and no name.
  auto right = plc.trigger(static_cast<std::uint16_t>(named->number), 9, 120s);
  REQUIRE(right.ok());
  CHECK(right->result.record.status == ResultStatus::kOk);
  CHECK(right->result.record.best_recipe == 0);
  service.stop();
}

// The frame above against a recipe of cartons far larger than its own: no box of the recipe
// fits the layer (no_layout), and the demo's recipe of 400 x 300 lays it out.
TEST_CASE(
    "a layer no box of the recipe fits fails with detail 8 and names the configured recipe that lays it "
    "out") {
  TempFrames frames({"recipe/block_400x300_smaller_than_420x315_helios2"});
  palletd::Config config = demo_config(frames.dir);
  config.formats.push_back(palletd::BoxFormat{0.500, 0.350, "500x350", 0.0});
  config.recipes.resize(2);
  config.recipes.push_back({21, "500x350", {static_cast<int>(config.formats.size()) - 1}, std::nullopt});
  config.pipeline.detection_timeout_ms = 120000.0;  // room for the sanitizer builds
  config.detection.layout.search.time_budget_ms = 5000.0;
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  auto result = plc.trigger(21, 8, 120s);
  REQUIRE(result.ok());
  const palletd::modbus::ResultRecord& rec = result->result.record;
  CHECK(rec.status == ResultStatus::kFailed);
  CHECK(rec.boxes.empty());
  CHECK(result->status.error_detail ==
        static_cast<std::uint16_t>(palletd::modbus::DetectionFailure::kRecipeMismatch));
  const palletd::Recipe* named = recipe_numbered(config, rec.best_recipe);
  REQUIRE(named != nullptr);
  CHECK(lists_format(config, *named, "400x300"));
  service.stop();
}

TEST_CASE("a size-range recipe answers with format 0xFFFF and each box's measured size in 910 + 2 i") {
  TempFrames frames({"12_block_300x200_holes_o3d303"});
  palletd::Config config = demo_config(frames.dir);
  palletd::Recipe unknown{90, "unknown cartons", {}, palletd::SizeRange{0.2, 0.8, 0.15, 0.6}};
  config.recipes.push_back(unknown);
  config.pipeline.detection_timeout_ms = 120000.0;  // room for the sanitizer builds
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  auto result = plc.trigger(90, 11, 120s);
  REQUIRE(result.ok());
  REQUIRE(result->result.ids_agree());  // 200 = 530 = 540 = 902 = 974
  const palletd::modbus::ResultRecord& rec = result->result.record;
  REQUIRE(rec.status == ResultStatus::kOk);
  CHECK(rec.formats_measured);
  CHECK(rec.boxes.size() == 12);
  CHECK_FALSE(rec.ambiguous);
  for (const palletd::modbus::BoxRecord& b : rec.boxes) {
    CHECK(b.format == 0xFFFF);
    CHECK(b.long_m == Approx(0.300).margin(0.010));
    CHECK(b.short_m == Approx(0.200).margin(0.010));
  }
  // The same frame with its recipe's formats: indices, the format's size, no measured flag.
  auto known = plc.trigger(static_cast<std::uint16_t>(config.recipes.front().number), 12, 120s);
  REQUIRE(known.ok());
  CHECK_FALSE(known->result.record.formats_measured);
  if (!known->result.record.boxes.empty()) CHECK(known->result.record.boxes.front().format != 0xFFFF);
  service.stop();
}

TEST_CASE("a shadow configuration with a size-range recipe detects with the range as the live one does") {
  TempFrames frames({"12_block_300x200_holes_o3d303"});
  palletd::Config config = demo_config(frames.dir);
  config.recipes.push_back({90, "unknown cartons", {}, palletd::SizeRange{0.2, 0.8, 0.15, 0.6}});
  config.pipeline.detection_timeout_ms = 120000.0;  // room for the sanitizer builds
  config.shadow = std::make_shared<palletd::Config>(config);
  palletd::Service service(config);
  REQUIRE(service.start().ok());
  palletd::modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, 1);
  REQUIRE(plc.connect().ok());
  REQUIRE(plc.trigger(90, 1, 120s).ok());
  for (int i = 0; i < 12000 && service.health().shadow_runs + service.health().shadow_skipped < 1; ++i)
    std::this_thread::sleep_for(10ms);
  const palletd::ServiceHealth h = service.health();
  CHECK(h.shadow_runs == 1);
  INFO(h.last_shadow_difference);
  CHECK(h.shadow_disagreements == 0);
  service.stop();
}
