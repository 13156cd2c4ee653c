#include <catch2/catch.hpp>

#include "palletd/modbus/register_map.hpp"
#include "result_record.hpp"

using palletd::Detection;
using palletd::DetectionStatus;

namespace {
palletd::DetectedBox box_at(double x, double y, double z, int pick) {
  palletd::DetectedBox b;
  b.center = {x, y, z};
  b.long_axis = {0.0, 1.0, 0.0};
  b.pick_index = pick;
  b.format = 1;
  b.score = 0.9;
  return b;
}
}  // namespace

TEST_CASE("a detection that ran maps to an ok record in the camera frame with 1-based pick indices") {
  Detection d;
  d.status = DetectionStatus::kOk;
  d.plane_camera.normal = {0.0, 0.0, -1.0};
  d.plane_camera.d = 1.5;  // plane z = 1.5 m
  d.boxes = {box_at(0.1, 0.2, 1.5, 0), box_at(-0.1, 0.2, 1.5, 1)};
  d.coverage = 0.97;
  d.ambiguous = true;
  d.outline_unobserved = true;
  const auto r = palletd::to_result_record(d, false);
  CHECK(r.status == palletd::modbus::ResultStatus::kOk);
  REQUIRE(r.boxes.size() == 2);
  CHECK(r.boxes[0].pick_index == 1);
  CHECK(r.boxes[1].pick_index == 2);
  CHECK(r.boxes[0].x_m == Approx(0.1));
  CHECK(r.boxes[0].yaw_deg == Approx(90.0));
  CHECK(r.layer_z_m == Approx(1.5));
  CHECK(r.ambiguous);
  CHECK(r.outline_unobserved);
  CHECK_FALSE(r.layer_clipped);
  CHECK(r.coverage == Approx(0.97));
}

TEST_CASE("base-frame poses are used when every box carries one") {
  Detection d;
  d.status = DetectionStatus::kOk;
  auto b = box_at(0.0, 0.0, 2.0, 0);
  b.base_position = Eigen::Vector3d(1.0, 2.0, 0.8);
  b.base_yaw_deg = -45.0;
  d.boxes = {b};
  const auto r = palletd::to_result_record(d, true);
  REQUIRE(r.boxes.size() == 1);
  CHECK(r.boxes[0].x_m == Approx(1.0));
  CHECK(r.boxes[0].z_m == Approx(0.8));
  CHECK(r.boxes[0].yaw_deg == Approx(-45.0));
  CHECK(r.layer_z_m == Approx(0.8));
}

TEST_CASE("a record marked failed keeps no boxes and carries the code and its detail") {
  Detection d;
  d.status = DetectionStatus::kOk;
  d.boxes = {box_at(0.1, 0.2, 1.5, 0), box_at(-0.1, 0.2, 1.5, 1)};
  auto r = palletd::to_result_record(d, false);
  REQUIRE(r.boxes_found == 2);
  palletd::mark_failed(r, palletd::modbus::ErrorCode::kDetectionTimeout, 312);
  CHECK(r.status == palletd::modbus::ResultStatus::kFailed);
  CHECK(r.error == palletd::modbus::ErrorCode::kDetectionTimeout);
  CHECK(r.error_detail == 312);
  CHECK(r.boxes.empty());
  CHECK(r.boxes_found == 0);
}

TEST_CASE("failed detections carry the failure as error detail, an empty layout is 'no boxes'") {
  Detection failed;
  failed.status = DetectionStatus::kNoPlane;
  const auto r = palletd::to_result_record(failed, false);
  CHECK(r.status == palletd::modbus::ResultStatus::kFailed);
  CHECK(r.error == palletd::modbus::ErrorCode::kDetectionFailed);
  CHECK(r.error_detail == static_cast<std::uint16_t>(palletd::modbus::DetectionFailure::kNoPlane));
  Detection empty;
  empty.status = DetectionStatus::kOk;
  CHECK(palletd::to_result_record(empty, false).status == palletd::modbus::ResultStatus::kNoBoxes);
  Detection mismatch;
  mismatch.status = DetectionStatus::kRecipeMismatch;
  mismatch.recipe_check.best_recipe = 7;
  const auto m = palletd::to_result_record(mismatch, false);
  CHECK(m.status == palletd::modbus::ResultStatus::kFailed);
  CHECK(m.error_detail == static_cast<std::uint16_t>(palletd::modbus::DetectionFailure::kRecipeMismatch));
  CHECK(m.best_recipe == 7);
  CHECK(palletd::to_result_record(failed, false).best_recipe == 0);
}

TEST_CASE("an empty pallet and a slip sheet are 'no boxes' with their detail, never a failure") {
  using palletd::modbus::ResultDetail;
  for (const auto& [status, detail] : {std::pair{DetectionStatus::kEmpty, ResultDetail::kEmpty},
                                       std::pair{DetectionStatus::kSlipSheet, ResultDetail::kSlipSheet}}) {
    Detection d;
    d.status = status;
    d.height_above_pallet_m = 0.01;
    d.layers_remaining = 0;
    const auto r = palletd::to_result_record(d, true);
    CHECK(r.status == palletd::modbus::ResultStatus::kNoBoxes);
    CHECK(r.error == palletd::modbus::ErrorCode::kNone);
    CHECK(r.detail == detail);
    CHECK(r.height_above_pallet_m == 0.01);
    CHECK(r.layers_remaining == 0);
  }
  Detection off;
  off.status = DetectionStatus::kOk;
  off.height_off_layers = true;
  CHECK(palletd::to_result_record(off, false).height_off_layers);
}

TEST_CASE("more boxes than the register map holds are counted but only 32 reported") {
  Detection d;
  d.status = DetectionStatus::kOk;
  for (int i = 0; i < 40; ++i) d.boxes.push_back(box_at(0.01 * i, 0.0, 1.0, i));
  const auto r = palletd::to_result_record(d, false);
  CHECK(r.boxes_found == 40);
  CHECK(r.boxes.size() == palletd::modbus::kMaxBoxes);
}

namespace {
palletd::BoxPick pick_of(bool pickable, palletd::PickBlock blocked_by) {
  palletd::BoxPick p;
  p.pickable = pickable;
  p.blocked_by = blocked_by;
  return p;
}
}  // namespace

TEST_CASE("with a gripper the record carries the groups, their TCP and each box's pick status") {
  using palletd::PickBlock;
  using palletd::modbus::PickStatus;
  Detection d;
  d.status = DetectionStatus::kOk;
  d.boxes = {box_at(0.1, 0.2, 1.5, 0), box_at(-0.1, 0.2, 1.5, 1), box_at(0.3, 0.2, 1.5, 2),
             box_at(0.5, 0.2, 1.5, 3), box_at(0.7, 0.2, 1.5, 4)};
  d.boxes[0].pick = pick_of(true, PickBlock::kNone);
  d.boxes[1].pick = pick_of(true, PickBlock::kNone);
  d.boxes[2].pick = pick_of(true, PickBlock::kNone);
  d.boxes[3].pick = pick_of(false, PickBlock::kNeighbour);
  d.boxes[4].pick = pick_of(false, PickBlock::kYawLimits);
  palletd::PickGroup pair;
  pair.boxes = {0, 1};
  pair.tcp.position_m = {1.0, 2.0, 0.75};
  pair.tcp.yaw_deg = 90.0;
  pair.tcp.base_frame = true;
  pair.pick_index = 0;
  palletd::PickGroup single;
  single.boxes = {2};
  single.tcp.position_m = {1.2, 2.0, 0.75};
  single.tcp.yaw_deg = -179.5;
  single.pick_index = 1;
  d.groups = {pair, single};
  const auto r = palletd::to_result_record(d, true);
  CHECK(r.picking);
  CHECK(r.groups_found == 2);
  CHECK(r.pickable_boxes == 3);
  REQUIRE(r.groups.size() == 2);
  CHECK(r.groups[0].first_box == 0);
  CHECK(r.groups[0].box_count == 2);
  CHECK(r.groups[0].pick_index == 1);
  CHECK(r.groups[0].x_m == Approx(1.0));
  CHECK(r.groups[0].z_m == Approx(0.75));
  CHECK(r.groups[0].yaw_deg == Approx(90.0));
  CHECK(r.groups[1].first_box == 2);
  CHECK(r.groups[1].box_count == 1);
  CHECK(r.groups[1].pick_index == 2);
  CHECK(r.groups[1].yaw_deg == Approx(-179.5));
  REQUIRE(r.boxes.size() == 5);
  CHECK(r.boxes[0].pick_status == PickStatus::kPickable);
  CHECK(r.boxes[2].pick_status == PickStatus::kPickable);
  CHECK(r.boxes[3].pick_status == PickStatus::kNeighbour);
  CHECK(r.boxes[4].pick_status == PickStatus::kYawLimits);
  CHECK(palletd::pick_status_of(pick_of(false, PickBlock::kRoi)) == PickStatus::kRoi);
  CHECK(palletd::pick_status_of(pick_of(false, PickBlock::kHigherLevel)) == PickStatus::kHigherLevel);

  // Encoded, the PLC finds the pair in group 0 and the statuses in 870 + i.
  palletd::modbus::RegisterImage image{};
  palletd::modbus::encode_result(r, 1, palletd::modbus::WordOrder::kHighWordFirst, image);
  CHECK(image[palletd::modbus::kRegPickFlags] == palletd::modbus::kPickGripper);
  CHECK(image[palletd::modbus::kRegGroupsReported] == 2);
  CHECK(image[palletd::modbus::kPickStatusStart + 3] == 4);
  CHECK(image[palletd::modbus::kPickStatusStart + 4] == 3);
}

TEST_CASE("without a gripper the record has no pick data") {
  Detection d;
  d.status = DetectionStatus::kOk;
  d.boxes = {box_at(0.1, 0.2, 1.5, 0)};
  const auto r = palletd::to_result_record(d, false);
  CHECK_FALSE(r.picking);
  CHECK(r.groups.empty());
  CHECK(r.pickable_boxes == 0);
}
