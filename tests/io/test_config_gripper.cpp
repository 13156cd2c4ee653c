// The `gripper` section: parsed into DetectionParams::gripper, compared, and each bad value an
// error with its line and key path.
#include <catch2/catch.hpp>

#include "config_failure.hpp"
#include "palletd/config/config.hpp"

using namespace palletd;
using Catch::Contains;

TEST_CASE("gripper: every key parses, and null or absent means no gripper") {
  const Config c = parse_config(R"(
gripper:
  footprint_mm: [820, 310]
  tcp_offset_mm: [12.5, -4]
  max_boxes: 2
  clearance_mm: 25
  yaw_limits_deg: [-90, 270]
  max_group_gap_mm: 15
  obstacle_height_mm: 45
)",
                                "gripper.yaml");
  REQUIRE(c.detection.gripper);
  const GripperParams& g = *c.detection.gripper;
  CHECK(g.footprint_mm == Eigen::Vector2d(820.0, 310.0));
  CHECK(g.tcp_offset_mm == Eigen::Vector2d(12.5, -4.0));
  CHECK(g.max_boxes == 2);
  CHECK(g.clearance_mm == 25.0);
  CHECK(g.yaw_min_deg == -90.0);
  CHECK(g.yaw_max_deg == 270.0);
  CHECK(g.max_group_gap_mm == 15.0);
  CHECK(g.obstacle_height_mm == 45.0);
  CHECK_FALSE(parse_config("gripper: null\n", "n.yaml").detection.gripper);
  CHECK_FALSE(parse_config("pipeline: {}\n", "n.yaml").detection.gripper);

  // Only the footprint is required; the rest keep their defaults.
  const Config minimal = parse_config("gripper:\n  footprint_mm: [400, 300]\n", "m.yaml");
  REQUIRE(minimal.detection.gripper);
  CHECK(minimal.detection.gripper->max_boxes == 1);
  CHECK(minimal.detection.gripper->clearance_mm == 10.0);
  CHECK(minimal.detection.gripper->yaw_min_deg == -180.0);

  // A changed gripper is a difference (reload, shadow comparisons).
  CHECK(config_differences(c, minimal) == std::vector<std::string>{"gripper"});
  CHECK(config_differences(minimal, minimal).empty());
}

TEST_CASE("gripper: bad values name the key and the line") {
  const test::ConfigFailure missing = test::config_failure_of("gripper:\n  max_boxes: 2\n");
  CHECK(missing.key == "gripper");
  CHECK_THAT(missing.what, Contains("footprint_mm"));
  CHECK(missing.line == 2);

  const test::ConfigFailure length =
      test::config_failure_of("pipeline: {}\ngripper:\n  footprint_mm: [400]\n");
  CHECK(length.line == 3);
  CHECK(length.key == "gripper.footprint_mm");
  CHECK_THAT(length.what, Contains("2 numbers"));

  const test::ConfigFailure zero = test::config_failure_of("gripper:\n  footprint_mm: [400, 0]\n");
  CHECK(zero.key == "gripper.footprint_mm[1]");
  CHECK(zero.line == 2);

  const test::ConfigFailure boxes =
      test::config_failure_of("gripper:\n  footprint_mm: [400, 300]\n  max_boxes: 0\n");
  CHECK(boxes.key == "gripper.max_boxes");
  CHECK(boxes.line == 3);

  const test::ConfigFailure yaw =
      test::config_failure_of("gripper:\n  footprint_mm: [400, 300]\n  yaw_limits_deg: [90, -90]\n");
  CHECK(yaw.key == "gripper.yaw_limits_deg");
  CHECK(yaw.line == 3);
  CHECK_THAT(yaw.what, Contains("below the maximum"));

  const test::ConfigFailure unknown =
      test::config_failure_of("gripper:\n  footprint_mm: [400, 300]\n  suction_cups: 4\n");
  CHECK(unknown.line == 3);
  CHECK_THAT(unknown.what, Contains("suction_cups"));

  const test::ConfigFailure shape = test::config_failure_of("gripper: [400, 300]\n");
  CHECK(shape.key == "gripper");
  CHECK(shape.line == 1);
}

TEST_CASE("check: the pick check's tolerances parse, default to 5 mm and 1 degree, bad ones name the line") {
  const Config defaults = parse_config("pipeline: {}\n", "d.yaml");
  CHECK(defaults.check.tolerance_mm == 5.0);
  CHECK(defaults.check.tolerance_deg == 1.0);
  const Config c = parse_config("check:\n  tolerance_mm: 8\n  tolerance_deg: 2.5\n", "c.yaml");
  CHECK(c.check.tolerance_mm == 8.0);
  CHECK(c.check.tolerance_deg == 2.5);
  CHECK(config_differences(defaults, c) == std::vector<std::string>{"check.tolerance_mm", "check.tolerance_deg"});
  const test::ConfigFailure negative = test::config_failure_of("pipeline: {}\ncheck:\n  tolerance_mm: -3\n");
  CHECK(negative.line == 3);
  CHECK(negative.key == "check.tolerance_mm");
  const test::ConfigFailure unknown =
      test::config_failure_of("check:\n  tolerance_deg: 1\n  tolerence_mm: 4\n");
  CHECK(unknown.line == 3);
  CHECK_THAT(unknown.what, Contains("tolerence_mm"));
}
