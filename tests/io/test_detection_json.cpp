// Detection JSON lines (shared/spec/detections.md): writer and parser.
#include <catch2/catch.hpp>

#include <cmath>

#include <nlohmann/json.hpp>

#include "palletd/results/detection_json.hpp"

using namespace palletd;
using Catch::Contains;

namespace {

/// A box of format 1 at (0.1, -0.05, 1.42) in the camera frame.
DetectedBox sample_box() {
  DetectedBox a;
  a.center = Eigen::Vector3d(0.1, -0.05, 1.42);
  a.long_axis = Eigen::Vector3d(1.0, 0.0, 0.0);
  a.normal = Eigen::Vector3d(0.0, 0.0, -1.0);
  a.long_m = 0.315;
  a.short_m = 0.232;
  a.format = 1;
  a.score = 0.97;
  a.pick_index = 1;
  return a;
}

Detection sample_detection() {
  Detection d;
  d.status = DetectionStatus::kOk;
  d.timing_ms = {{"total", 12.5}, {"plane", 3.25}, {"layout", 7.0}};
  d.plane_camera.normal = Eigen::Vector3d(0.0, 0.0, -1.0);
  d.plane_camera.d = 1.42;
  d.layer_area_m2 = 0.66;
  d.coverage = 0.98;
  d.ambiguous = true;
  d.layout_confidence = 0.42;
  d.recipe_check.checked = true;
  d.recipe_check.best_recipe = 4;
  d.recipe_check.formats = {FormatCheck{0, 0.4, 0.3, 0.405, -1.0, 3, 0, true}};
  d.boxes = {sample_box(), sample_box()};
  DetectedBox& a = d.boxes[0];
  a.score_terms.support = 0.91;
  a.score_terms.position_sigma_mm = 1.25;
  a.score_terms.contested = true;
  DetectedBox& b = d.boxes[1];
  b.center.x() = -0.2;
  b.format = 0;
  b.pick_index = 0;
  b.base_position = Eigen::Vector3d(1.0, 2.0, 0.5);
  b.base_yaw_deg = -90.0;
  b.partly_unseen = true;
  return d;
}

}  // namespace

TEST_CASE("detection line has the keys of the spec in order") {
  const std::string line = detection_to_json_line(sample_detection(), "data/f0001");
  CHECK(line.find('\n') == std::string::npos);
  const auto j = nlohmann::ordered_json::parse(line);
  std::vector<std::string> keys;
  for (const auto& item : j.items()) keys.push_back(item.key());
  const std::vector<std::string> first = {"frame", "status", "message", "timing_ms", "layer", "ambiguous"};
  REQUIRE(keys.size() >= first.size() + 1);
  CHECK(std::vector<std::string>(keys.begin(), keys.begin() + 6) == first);
  CHECK(keys.back() == "boxes");
  CHECK(j["frame"] == "data/f0001");
  CHECK(j["status"] == "ok");
  CHECK(j["timing_ms"].begin().key() == "total");
  CHECK(j["timing_ms"]["total"] == 12.5);
  CHECK(j["layer"]["plane"] == nlohmann::ordered_json({0.0, 0.0, -1.0, 1.42}));
  CHECK(j["layer"]["coverage"] == 0.98);
  CHECK(j["ambiguous"] == true);
  CHECK(j["outline_unobserved"] == false);
  Detection unobserved = sample_detection();
  unobserved.outline_unobserved = true;
  CHECK(nlohmann::json::parse(detection_to_json_line(unobserved, "f"))["outline_unobserved"] == true);
  REQUIRE(j["boxes"].size() == 2);
  CHECK(j["boxes"][0]["size"] == nlohmann::ordered_json({0.315, 0.232}));
  CHECK(j["boxes"][0]["format"] == 1);
  CHECK_FALSE(j["boxes"][0].contains("base"));
  CHECK(j["boxes"][1]["base"]["position"] == nlohmann::ordered_json({1.0, 2.0, 0.5}));
  CHECK(j["boxes"][1]["base"]["yaw_deg"] == -90.0);
  CHECK(j["boxes"][1]["pick_index"] == 0);
  CHECK(j["layout_confidence"] == 0.42);
  CHECK(j["recipe_check"]["best_recipe"] == 4);
  CHECK(j["recipe_check"]["formats"][0]["measured_mm"][0] == Approx(405.0));
  CHECK(j["recipe_check"]["formats"][0]["measured_mm"][1].is_null());
  CHECK(j["recipe_check"]["formats"][0]["boxes_measured"] == nlohmann::ordered_json({3, 0}));
  CHECK(j["boxes"][0].contains("measured_size"));
  const auto& terms = j["boxes"][0]["score_terms"];
  CHECK(terms["support"] == 0.91);
  CHECK(terms["position_sigma_mm"] == 1.25);
  CHECK(terms["contested"] == true);
  CHECK(j["boxes"][1]["score_terms"]["contested"] == false);
  for (const char* key : {"inside", "edge_seams", "interior_seam", "refine_shift_mm", "pitch_mm", "partly_unseen",
                          "layout_ambiguous", "outline_unobserved"})
    CHECK(terms.contains(key));
}

TEST_CASE("detection line round trip through the parser") {
  const Detection d = sample_detection();
  auto parsed = parse_detection_line(detection_to_json_line(d, "x/y"));
  REQUIRE(parsed.ok());
  const ParsedDetection& p = *parsed;
  CHECK(p.frame == "x/y");
  CHECK(p.status == "ok");
  CHECK(p.timing_ms == d.timing_ms);
  CHECK(p.plane.normal == d.plane_camera.normal);
  CHECK(p.plane.d == d.plane_camera.d);
  CHECK(p.area_m2 == 0.66);
  CHECK(p.coverage == 0.98);
  CHECK(p.ambiguous);
  REQUIRE(p.boxes.size() == 2);
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(p.boxes[i].center == d.boxes[i].center);
    CHECK(p.boxes[i].long_axis == d.boxes[i].long_axis);
    CHECK(p.boxes[i].normal == d.boxes[i].normal);
    CHECK(p.boxes[i].long_m == d.boxes[i].long_m);
    CHECK(p.boxes[i].short_m == d.boxes[i].short_m);
    CHECK(p.boxes[i].format == d.boxes[i].format);
    CHECK(p.boxes[i].score == d.boxes[i].score);
    CHECK(p.boxes[i].pick_index == d.boxes[i].pick_index);
    CHECK(p.boxes[i].partly_unseen == d.boxes[i].partly_unseen);
  }
  CHECK_FALSE(p.boxes[0].base_position.has_value());
  REQUIRE(p.boxes[1].base_position.has_value());
  CHECK(*p.boxes[1].base_position == Eigen::Vector3d(1.0, 2.0, 0.5));
  CHECK(p.boxes[1].base_yaw_deg == -90.0);
  // Heights unknown: null, read back as unknown.
  CHECK_FALSE(p.height_above_pallet_m.has_value());
  CHECK_FALSE(p.layers_remaining.has_value());
}

TEST_CASE("detection line: layer height, layers left, ambiguity reason, the no-box statuses") {
  Detection d = sample_detection();
  d.height_above_pallet_m = 0.75;
  d.layers_remaining = 3;
  d.ambiguity_reason = "another arrangement of 4 boxes explains the outline and the seams nearly as well";
  d.interior_seams.length_m = 2.0;
  d.interior_seams.seen_m = 1.5;
  const auto j = nlohmann::json::parse(detection_to_json_line(d, "f"));
  CHECK(j["layer"]["height_above_pallet_m"] == 0.75);
  CHECK(j["layer"]["seams_seen"] == 0.75);
  CHECK(j["layers_remaining"] == 3);
  CHECK(j["ambiguity_reason"] == d.ambiguity_reason);
  auto parsed = parse_detection_line(detection_to_json_line(d, "f"));
  REQUIRE(parsed.ok());
  CHECK(parsed->height_above_pallet_m == 0.75);
  CHECK(parsed->layers_remaining == 3);
  CHECK(parsed->ambiguity_reason == d.ambiguity_reason);

  Detection sheet;
  sheet.status = DetectionStatus::kSlipSheet;
  const auto s = nlohmann::json::parse(detection_to_json_line(sheet, "g"));
  CHECK(s["status"] == "slip_sheet");
  CHECK(s["boxes"].empty());
  CHECK(s["layers_remaining"].is_null());
  CHECK(s["layer"]["seams_seen"].is_null());
  sheet.status = DetectionStatus::kEmpty;
  CHECK(nlohmann::json::parse(detection_to_json_line(sheet, "g"))["status"] == "empty");
  CHECK_FALSE(parse_detection_line(R"({"frame":"f","status":"ok","boxes":[],"layers_remaining":"3"})").ok());
}

TEST_CASE("a failed frame still makes a complete line") {
  Detection d;
  d.status = DetectionStatus::kNoPlane;
  d.message = "no plane within 35 degrees of the view axis";
  d.timing_ms["total"] = 4.0;
  const std::string line = detection_to_json_line(d, "f \"quoted\"");
  auto p = parse_detection_line(line);
  REQUIRE(p.ok());
  CHECK(p->status == "no_plane");
  CHECK(p->message == d.message);
  CHECK(p->frame == "f \"quoted\"");
  CHECK(p->boxes.empty());
}

TEST_CASE("NaN values are written as null and read back as NaN") {
  Detection d = sample_detection();
  d.boxes[0].score = std::nan("");
  const std::string line = detection_to_json_line(d, "n");
  CHECK_THAT(line, Contains("\"score\":null"));
  auto p = parse_detection_line(line);
  REQUIRE(p.ok());
  CHECK(std::isnan(p->boxes[0].score));
}

TEST_CASE("bad detection lines are errors") {
  CHECK_THAT(parse_detection_line("{").error(), Contains("not valid JSON"));
  CHECK_THAT(parse_detection_line("[]").error(), Contains("JSON object"));
  CHECK_THAT(parse_detection_line(R"({"status":"ok","boxes":[]})").error(), Contains("'frame'"));
  CHECK_THAT(parse_detection_line(R"({"frame":"a","status":"ok"})").error(), Contains("'boxes'"));
  CHECK_THAT(parse_detection_line(R"({"frame":"a","status":"ok","boxes":[{"center":[0,0,1]}]})").error(),
             Contains("boxes[0]") && Contains("long_axis"));
  CHECK_THAT(parse_detection_line(
                 R"({"frame":"a","status":"ok","boxes":[{"center":[0,0,1],"long_axis":[1,0,0],)"
                 R"("normal":[0,0,-1],"size":[0.3],"format":0}]})")
                 .error(),
             Contains("boxes[0].size"));
  const std::string box = R"({"center":[0,0,1],"long_axis":[1,0,0],"normal":[0,0,-1],"size":[0.3,0.2],"format":0)";
  CHECK_THAT(parse_detection_line(R"({"frame":"a","status":"ok","boxes":[)" + box + R"(,"partly_unseen":1}]})").error(),
             Contains("boxes[0].partly_unseen"));
  auto without = parse_detection_line(R"({"frame":"a","status":"ok","boxes":[)" + box + "}]}");
  REQUIRE(without.ok());
  CHECK_FALSE(without->boxes.at(0).partly_unseen);  // lines written before the key existed
  // Extra keys are ignored; optional keys take defaults.
  auto minimal = parse_detection_line(R"({"frame":"a","status":"no_layer","boxes":[],"extra":{"k":1}})");
  REQUIRE(minimal.ok());
  CHECK(minimal->status == "no_layer");
  CHECK_FALSE(minimal->ambiguous);
}

TEST_CASE("detection line: the frame's health, null where a figure was not measured") {
  Detection d = sample_detection();
  CHECK_FALSE(nlohmann::json::parse(detection_to_json_line(d, "f")).contains("health"));  // unread frame
  d.health.measured = true;
  d.health.roi_pixels = 1000;
  d.health.invalid_fraction = 0.125;
  d.health.flying_fraction = 0.25;
  d.health.plane_noise_mm = 3.5;
  const nlohmann::json h = nlohmann::json::parse(detection_to_json_line(d, "f"))["health"];
  CHECK(h["roi_pixels"] == 1000);
  CHECK(h["invalid_fraction"] == 0.125);
  CHECK(h["flying_fraction"] == 0.25);
  CHECK(h["plane_noise_mm"] == 3.5);
  CHECK(h["saturated_fraction"].is_null());
  CHECK(h["noise_ratio"].is_null());
}

TEST_CASE("detection line: pickable, blocked_by and tcp per box, and the groups, with a gripper") {
  Detection d = sample_detection();
  CHECK_FALSE(nlohmann::json::parse(detection_to_json_line(d, "f")).contains("groups"));  // no gripper
  d.boxes[0].pick = BoxPick{false, PickBlock::kHigherLevel, TcpPose{Eigen::Vector3d(0.1, -0.05, 1.42), 30.0, false}};
  d.boxes[1].pick = BoxPick{true, PickBlock::kNone, TcpPose{Eigen::Vector3d(1.0, 2.0, 0.5), -90.0, true}};
  d.groups = {PickGroup{{1}, TcpPose{Eigen::Vector3d(1.0, 2.05, 0.5), 90.0, true}, 0}};
  const auto j = nlohmann::json::parse(detection_to_json_line(d, "f"));
  CHECK(j["boxes"][0]["pickable"] == false);
  CHECK(j["boxes"][0]["blocked_by"] == "higher_level");
  CHECK(j["boxes"][0]["tcp"]["position"] == nlohmann::json({0.1, -0.05, 1.42}));
  CHECK(j["boxes"][0]["tcp"]["yaw_deg"] == 30.0);
  CHECK(j["boxes"][1]["pickable"] == true);
  CHECK(j["boxes"][1]["blocked_by"] == "");
  REQUIRE(j["groups"].size() == 1);
  CHECK(j["groups"][0]["boxes"] == nlohmann::json({1}));
  CHECK(j["groups"][0]["tcp"]["position"] == nlohmann::json({1.0, 2.05, 0.5}));
  CHECK(j["groups"][0]["tcp"]["yaw_deg"] == 90.0);
  CHECK(j["groups"][0]["pick_index"] == 0);
  for (const PickBlock block : {PickBlock::kRoi, PickBlock::kYawLimits, PickBlock::kNeighbour}) {
    d.boxes[0].pick->blocked_by = block;
    CHECK(nlohmann::json::parse(detection_to_json_line(d, "f"))["boxes"][0]["blocked_by"] == to_string(block));
  }
}
