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
