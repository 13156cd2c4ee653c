#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "palletd/modbus/register_map.hpp"

using namespace palletd::modbus;

TEST_CASE("32-bit values are split into words in the configured order", "[modbus][register_map]") {
  std::uint16_t regs[2] = {};
  put_u32(regs, 0x12345678u, WordOrder::kHighWordFirst);
  CHECK(regs[0] == 0x1234);
  CHECK(regs[1] == 0x5678);
  CHECK(get_u32(regs, WordOrder::kHighWordFirst) == 0x12345678u);
  put_u32(regs, 0x12345678u, WordOrder::kLowWordFirst);
  CHECK(regs[0] == 0x5678);
  CHECK(regs[1] == 0x1234);
  CHECK(get_u32(regs, WordOrder::kLowWordFirst) == 0x12345678u);

  for (const std::int32_t v : {0, 1, -1, -123456, std::numeric_limits<std::int32_t>::min(),
                               std::numeric_limits<std::int32_t>::max()}) {
    for (const WordOrder order : {WordOrder::kHighWordFirst, WordOrder::kLowWordFirst}) {
      put_i32(regs, v, order);
      CHECK(get_i32(regs, order) == v);
    }
  }
  put_i32(regs, -2, WordOrder::kHighWordFirst);
  CHECK(regs[0] == 0xFFFF);
  CHECK(regs[1] == 0xFFFE);
}

TEST_CASE("engineering units scale to 0.1 mm, 0.01 deg and per mille", "[modbus][register_map]") {
  CHECK(metres_to_tenth_mm(1.23456) == 12346);
  CHECK(metres_to_tenth_mm(-0.5) == -5000);
  CHECK(metres_to_tenth_mm(1e9) == std::numeric_limits<std::int32_t>::max());
  CHECK(metres_to_tenth_mm(std::nan("")) == 0);
  CHECK(tenth_mm_to_metres(12346) == Approx(1.2346));
  CHECK(degrees_to_hundredths(12.346) == 1235);
  CHECK(degrees_to_hundredths(-12.346) == -1235);
  CHECK(degrees_to_hundredths(190.0) == -17000);
  CHECK(degrees_to_hundredths(-190.0) == 17000);
  CHECK(degrees_to_hundredths(180.0) == 18000);
  CHECK(degrees_to_hundredths(-180.0) == -18000);
  CHECK(degrees_to_hundredths(720.5) == 50);
  CHECK(unit_to_permille(0.9876) == 988);
  CHECK(unit_to_permille(1.5) == 1000);
  CHECK(unit_to_permille(-0.1) == 0);
  CHECK(milliseconds_to_register(70000.0) == 65535);
  CHECK(milliseconds_to_register(12.6) == 13);
}

namespace {
ResultRecord make_result(int boxes) {
  ResultRecord r;
  r.request_id = 4242;
  r.recipe = 3;
  r.status = ResultStatus::kOk;
  r.boxes_found = static_cast<std::uint16_t>(boxes);
  r.ambiguous = true;
  r.layer_clipped = true;
  r.outline_unobserved = true;
  r.layer_z_m = -1.2345;
  r.coverage = 0.97;
  r.layout_confidence = 0.873;
  r.best_recipe = 12;
  for (int i = 0; i < boxes; ++i) {
    BoxRecord b;
    b.x_m = 0.1 * i - 1.0;
    b.y_m = -0.05 * i;
    b.z_m = 1.5 + 0.001 * i;
    b.yaw_deg = -170.0 + 11.0 * i;
    b.format = static_cast<std::uint16_t>(i % 3);
    b.score = 0.5 + 0.01 * i;
    b.pick_index = static_cast<std::uint16_t>(i + 1);
    r.boxes.push_back(b);
  }
  return r;
}
}  // namespace

TEST_CASE("a result encodes into 200..532 and decodes back in both word orders",
          "[modbus][register_map]") {
  for (const WordOrder order : {WordOrder::kHighWordFirst, WordOrder::kLowWordFirst}) {
    RegisterImage image{};
    image.fill(0xABCD);  // stale content must not survive in unused slots
    const ResultRecord in = make_result(40);
    encode_result(in, 77, order, image);
    CHECK(image[kRegResultId] == 77);
    CHECK(image[kResultIdCopy] == 77);
    CHECK(image[kRegBoxesFound] == 40);
    CHECK(image[kRegBoxesReported] == 32);
    CHECK(image[kRegResultFlags] == (kResAmbiguous | kResLayerClipped | kResOutlineUnobserved));
    CHECK(image[kRegCoverage] == 970);
    CHECK(image[kRegLayoutConfidence] == 873);
    CHECK(image[kRegBestRecipe] == 12);
    CHECK(image[kRegBestRecipe + 1] == 0);  // the gap 533..539 reads 0
    // outside the block untouched
    CHECK(image[kResultStart - 1] == 0xABCD);
    const DecodedResult out = decode_result(image, order);
    CHECK(out.result_id == 77);
    CHECK(out.result_id_copy == 77);
    CHECK(out.record.request_id == 4242);
    CHECK(out.record.recipe == 3);
    CHECK(out.record.layer_z_m == Approx(-1.2345).margin(1e-4));
    CHECK(out.record.ambiguous);
    CHECK_FALSE(out.record.budget_exhausted);
    CHECK(out.record.layer_clipped);
    CHECK(out.record.outline_unobserved);
    CHECK(out.record.layout_confidence == Approx(0.873).margin(0.0005));
    CHECK(out.record.best_recipe == 12);
    REQUIRE(out.record.boxes.size() == 32);
    for (std::size_t i = 0; i < 32; ++i) {
      const BoxRecord& a = in.boxes[i];
      const BoxRecord& b = out.record.boxes[i];
      CHECK(b.x_m == Approx(a.x_m).margin(0.5e-4));
      CHECK(b.y_m == Approx(a.y_m).margin(0.5e-4));
      CHECK(b.z_m == Approx(a.z_m).margin(0.5e-4));
      CHECK(b.yaw_deg == Approx(std::remainder(a.yaw_deg, 360.0)).margin(0.005));
      CHECK(b.format == a.format);
      CHECK(b.score == Approx(a.score).margin(0.0005));
      CHECK(b.pick_index == a.pick_index);
    }
  }
  // A smaller result afterwards zeroes the slots the bigger one used.
  RegisterImage image{};
  encode_result(make_result(32), 1, WordOrder::kHighWordFirst, image);
  encode_result(make_result(2), 2, WordOrder::kHighWordFirst, image);
  for (std::uint16_t a = kBoxStart + 2 * kBoxStride; a < kResultIdCopy; ++a) {
    INFO("register " << a);
    CHECK(image[a] == 0);
  }
  // The decoded word order matters: reading low-first data as high-first gives other values.
  RegisterImage low{};
  encode_result(make_result(3), 5, WordOrder::kLowWordFirst, low);
  CHECK(decode_result(low, WordOrder::kHighWordFirst).record.boxes[0].x_m !=
        Approx(make_result(3).boxes[0].x_m).margin(1e-3));
}

TEST_CASE("the result extension 130..134: detail, height above the pallet, layers left",
          "[modbus][register_map]") {
  for (const WordOrder order : {WordOrder::kHighWordFirst, WordOrder::kLowWordFirst}) {
    RegisterImage image{};
    image.fill(0xABCD);
    ResultRecord in = make_result(2);
    in.height_above_pallet_m = 0.7512;
    in.layers_remaining = 3;
    in.height_off_layers = true;
    encode_result(in, 9, order, image);
    CHECK(image[kRegResultDetail] == 0);
    CHECK(image[kRegLayerInfoFlags] == (kLayerHeightKnown | kLayersRemainingKnown));
    CHECK(image[kRegLayersRemaining] == 3);
    CHECK((image[kRegResultFlags] & kResHeightOffLayers) != 0);
    for (std::uint16_t a = kRegLayersRemaining + 1; a < kResultExtStart + kResultExtCount; ++a) CHECK(image[a] == 0);
    CHECK(image[kResultExtStart + kResultExtCount] == 0xABCD);  // the rest of the gap untouched
    const DecodedResult out = decode_result(image, order);
    REQUIRE(out.record.height_above_pallet_m);
    CHECK(*out.record.height_above_pallet_m == Approx(0.7512).margin(1e-4));
    CHECK(out.record.layers_remaining == 3);
    CHECK(out.record.height_off_layers);

    // An empty pallet: no boxes, detail 5; heights unknown read as unknown.
    ResultRecord empty;
    empty.status = ResultStatus::kNoBoxes;
    empty.detail = ResultDetail::kEmpty;
    encode_result(empty, 10, order, image);
    CHECK(image[kRegResultDetail] == 5);
    CHECK(image[kRegLayerInfoFlags] == 0);
    CHECK(image[kRegHeightAbovePallet] == 0);
    const DecodedResult e = decode_result(image, order);
    CHECK(e.record.detail == ResultDetail::kEmpty);
    CHECK_FALSE(e.record.height_above_pallet_m);
    CHECK_FALSE(e.record.layers_remaining);
    clear_result(image);
    CHECK(image[kRegResultDetail] == 0);
  }
}

TEST_CASE("the pick check registers 135..139 encode and decode back, 0 on a detection's result",
          "[modbus][register_map]") {
  RegisterImage image{};
  ResultRecord in = make_result(3);
  in.check = CheckRecord{CheckResult::kNeighbourMoved, 2, 1, 3, 7.0};  // 7 m saturates at 6553.5 mm
  encode_result(in, 11, WordOrder::kLowWordFirst, image);
  CHECK(image[kRegCheckResult] == 4);
  CHECK(image[kRegCheckBoxesGone] == 2);
  CHECK(image[kRegCheckBoxesMoved] == 1);
  CHECK(image[kRegCheckMovedSlot] == 3);
  CHECK(image[kRegCheckLargestMove] == 65535);
  const DecodedResult out = decode_result(image, WordOrder::kLowWordFirst);
  REQUIRE(out.record.check);
  CHECK(out.record.check->result == CheckResult::kNeighbourMoved);
  CHECK(out.record.check->moved_slot == 3);
  CHECK(out.record.check->largest_move_m == Approx(6.5535));
  in.check->largest_move_m = 0.0123;
  encode_result(in, 12, WordOrder::kHighWordFirst, image);
  CHECK(image[kRegCheckLargestMove] == 123);
  in.check.reset();
  encode_result(in, 13, WordOrder::kHighWordFirst, image);
  for (std::uint16_t a = kRegCheckResult; a <= kRegCheckLargestMove; ++a) CHECK(image[a] == 0);
  CHECK_FALSE(decode_result(image, WordOrder::kHighWordFirst).record.check);
}

TEST_CASE("the status block carries version, format flags and the test pattern",
          "[modbus][register_map]") {
  StatusRecord s;
  s.status_word = kStReady | kStCameraOk;
  s.error = ErrorCode::kCameraDisconnected;
  s.error_detail = 9;
  s.frames_grabbed = 0x00012345u;
  s.poses_in_camera_frame = true;
  s.latency_ms = 123.4;
  RegisterImage image{};
  encode_status(s, WordOrder::kLowWordFirst, image);
  CHECK(image[kRegInterfaceVersion] == 1);
  CHECK(image[kRegFormatFlags] == (kFmtLowWordFirst | kFmtCameraFrame));
  CHECK(image[kRegTestPattern] == 0x5678);
  CHECK(image[kRegTestPattern + 1] == 0x1234);
  CHECK(image[kRegErrorCode] == 4);
  CHECK(image[kRegLatencyMs] == 123);
  const StatusRecord back = decode_status(image, WordOrder::kLowWordFirst);
  CHECK(back.frames_grabbed == 0x00012345u);
  CHECK(back.error_detail == 9);
  encode_status(s, WordOrder::kHighWordFirst, image);
  CHECK(image[kRegFormatFlags] == kFmtCameraFrame);
  CHECK(image[kRegTestPattern] == 0x1234);
  CHECK(image[kRegFramesGrabbed] == 0x0001);
}

TEST_CASE("the camera fault counters follow the status block at 118..129, 32 bits each in the word order",
          "[modbus][register_map]") {
  // The registers of interface version 1 before the counters stay where they were.
  CHECK(kRegCameraReconnects == 117);
  CHECK(kRegIncompleteFrames == 118);
  CHECK(kRegResentPackets + 2 == kStatusStart + kStatusCount);
  CHECK(kStatusStart + kStatusCount <= kResultStart);

  StatusRecord s;
  s.frames_grabbed = 70000;
  s.camera_reconnects = 3;
  CameraFaultCounters& f = s.camera_faults;
  f.incomplete_frames = 0x00010002u;
  f.grab_timeouts = 0x00030004u;
  f.dropped_frames = 5;
  f.camera_losses = 0x00060000u;
  f.camera_restarts = 7;
  f.resent_packets = 0xFFFFFFFFu;
  RegisterImage image{};
  encode_status(s, WordOrder::kHighWordFirst, image);
  CHECK(image[kRegCameraReconnects] == 3);
  CHECK(image[kRegIncompleteFrames] == 0x0001);
  CHECK(image[kRegIncompleteFrames + 1] == 0x0002);
  CHECK(image[kRegGrabTimeouts] == 0x0003);
  CHECK(image[kRegGrabTimeouts + 1] == 0x0004);
  CHECK(image[kRegDroppedFrames + 1] == 5);
  CHECK(image[kRegCameraLosses] == 0x0006);
  CHECK(image[kRegCameraRestarts + 1] == 7);
  CHECK(image[kRegResentPackets] == 0xFFFF);
  CHECK(image[kRegResentPackets + 1] == 0xFFFF);
  CHECK(image[kStatusStart + kStatusCount] == 0);  // the gap after the block stays 0
  CHECK(decode_status(image, WordOrder::kHighWordFirst).camera_faults == f);

  RegisterImage low{};
  encode_status(s, WordOrder::kLowWordFirst, low);
  CHECK(low[kRegIncompleteFrames] == 0x0002);
  CHECK(low[kRegIncompleteFrames + 1] == 0x0001);
  CHECK(low[kRegCameraLosses] == 0x0000);
  CHECK(low[kRegCameraLosses + 1] == 0x0006);
  CHECK(decode_status(low, WordOrder::kLowWordFirst).camera_faults == f);
  // Decoded in the wrong order, the counters read differently (the order matters).
  CHECK_FALSE(decode_status(low, WordOrder::kHighWordFirst).camera_faults == f);
}

TEST_CASE("the Modbus connection block 140..145: evictions and refusals as uint32, open and cap",
          "[modbus][register_map]") {
  CHECK(kConnectionStart >= kResultExtStart + kResultExtCount);  // after the result extension
  CHECK(kConnectionStart + kConnectionCount <= kResultStart);
  StatusRecord s;
  s.connections.evicted = 0x00020003u;
  s.connections.refused = 9;
  s.connections.open = 16;
  s.connections.max_connections = 16;
  for (const WordOrder order : {WordOrder::kHighWordFirst, WordOrder::kLowWordFirst}) {
    RegisterImage image{};
    encode_status(s, order, image);
    const bool high_first = order == WordOrder::kHighWordFirst;
    CHECK(image[kRegConnectionsEvicted] == (high_first ? 0x0002 : 0x0003));
    CHECK(image[kRegConnectionsEvicted + 1] == (high_first ? 0x0003 : 0x0002));
    CHECK(image[kRegConnectionsRefused + (high_first ? 1 : 0)] == 9);
    CHECK(image[kRegOpenConnections] == 16);
    CHECK(image[kRegMaxConnections] == 16);
    CHECK(image[kConnectionStart + kConnectionCount] == 0);  // the gap after the block stays 0
    CHECK(decode_status(image, order).connections == s.connections);
    // A result does not clear the connection block.
    clear_result(image);
    CHECK(image[kRegMaxConnections] == 16);
  }
}

TEST_CASE("the cell health block 146..155: flags, window, shares in per mille, ratio x100, drift",
          "[modbus][register_map]") {
  CHECK(kHealthStart == kConnectionStart + kConnectionCount);
  CHECK(kHealthStart + kHealthCount <= kResultStart);
  StatusRecord s;
  s.health.flags = kHealthInvalid | kHealthDrift | kHealthDriftReference | kHealthDriftMeasured;
  s.health.frames = 20;
  s.health.invalid_fraction = 0.1234;
  s.health.flying_fraction = 0.5;
  s.health.saturated_fraction = 0.0;
  s.health.noise_ratio = 1.57;
  s.health.drift_shift_mm = 12.34;
  s.health.drift_angle_deg = 0.456;
  RegisterImage image{};
  encode_status(s, WordOrder::kHighWordFirst, image);
  CHECK(image[kRegHealthFlags] == 0x0071);
  CHECK(image[kRegHealthFrames] == 20);
  CHECK(image[kRegInvalidPermille] == 123);
  CHECK(image[kRegFlyingPermille] == 500);
  CHECK(image[kRegNoiseRatio] == 157);
  CHECK(image[kRegDriftShift] == 123);  // 0.1 mm
  CHECK(image[kRegDriftAngle] == 46);   // 0.01 deg
  CHECK(image[kHealthStart + kHealthCount] == 0);  // the gap after the block stays 0
  const HealthRecord back = decode_status(image, WordOrder::kHighWordFirst).health;
  CHECK(back.flags == s.health.flags);
  CHECK(back.drift_shift_mm == Approx(12.3));
  CHECK(back.noise_ratio == Approx(1.57));
  // A camera knocked far off saturates instead of wrapping.
  s.health.drift_shift_mm = 1e6;
  encode_status(s, WordOrder::kHighWordFirst, image);
  CHECK(image[kRegDriftShift] == 65535);
}

namespace {
GroupRecord make_group(std::uint16_t first_box, std::uint16_t box_count, std::uint16_t pick_index) {
  return GroupRecord{0.25 * first_box - 1.0, -0.1234 - 0.01 * first_box, 0.8 + 0.001 * box_count,
                     -90.0 + 10.0 * pick_index, box_count, first_box, pick_index};
}

/// Five boxes: slots 0-1 one pick, slot 3 another; slot 2 waits for a neighbour, slot 4 is at a wall.
ResultRecord make_picking_result() {
  ResultRecord r = make_result(5);
  r.picking = true;
  r.boxes[2].pick_status = PickStatus::kNeighbour;
  r.boxes[4].pick_status = PickStatus::kRoi;
  r.groups = {make_group(0, 2, 1), make_group(3, 1, 2)};
  r.groups_found = 2;
  r.pickable_boxes = 3;
  return r;
}
}  // namespace

TEST_CASE("a result with picks encodes the pick block and decodes back in both word orders",
          "[modbus][register_map]") {
  CHECK(kRegisterCount == 975);  // the size block 910..974 ends the register space
  for (const WordOrder order : {WordOrder::kHighWordFirst, WordOrder::kLowWordFirst}) {
    RegisterImage image{};
    image.fill(0xABCD);
    const ResultRecord in = make_picking_result();
    encode_result(in, 77, order, image);
    CHECK(image[kRegPickResultId] == 77);
    CHECK(image[kPickIdCopy] == 77);
    CHECK(image[kRegPickFlags] == kPickGripper);
    CHECK(image[kRegGroupsFound] == 2);
    CHECK(image[kRegGroupsReported] == 2);
    CHECK(image[kRegPickableBoxes] == 3);
    for (std::uint16_t a = kRegBestRecipe + 1; a < kPickStart; ++a) CHECK(image[a] == 0);
    for (std::uint16_t a = kRegPickableBoxes + 1; a < kGroupStart; ++a) CHECK(image[a] == 0);
    // group 1: TCP, box count, first box slot, pick index at 560..569
    const std::uint16_t* g1 = &image[kGroupStart + kGroupStride];
    const bool high_first = order == WordOrder::kHighWordFirst;
    CHECK(get_i32(g1, order) == -2500);  // x -0.25 m = 0xFFFFF63C in the word order
    CHECK(g1[0] == (high_first ? 0xFFFF : 0xF63C));
    CHECK(g1[1] == (high_first ? 0xF63C : 0xFFFF));
    CHECK(get_i32(g1 + 4, order) == 8010);
    CHECK(g1[6] == static_cast<std::uint16_t>(degrees_to_hundredths(-70.0)));
    CHECK(g1[7] == 1);
    CHECK(g1[8] == 3);
    CHECK(g1[9] == 2);
    for (std::uint16_t a = kGroupStart + 2 * kGroupStride; a < kPickStatusStart; ++a) CHECK(image[a] == 0);
    const std::uint16_t statuses[5] = {0, 0, 4, 0, 1};
    for (std::uint16_t i = 0; i < 5; ++i) CHECK(image[kPickStatusStart + i] == statuses[i]);
    for (std::uint16_t a = kPickStatusStart + 5; a < kPickIdCopy; ++a) CHECK(image[a] == 0);

    const DecodedResult out = decode_result(image, order);
    CHECK(out.pick_result_id == 77);
    CHECK(out.pick_result_id_copy == 77);
    CHECK(out.ids_agree());
    CHECK(out.record.picking);
    CHECK(out.record.groups_found == 2);
    CHECK(out.record.pickable_boxes == 3);
    REQUIRE(out.record.groups.size() == 2);
    for (std::size_t g = 0; g < 2; ++g) {
      const GroupRecord& a = in.groups[g];
      const GroupRecord& b = out.record.groups[g];
      CHECK(b.x_m == Approx(a.x_m).margin(0.5e-4));
      CHECK(b.y_m == Approx(a.y_m).margin(0.5e-4));
      CHECK(b.z_m == Approx(a.z_m).margin(0.5e-4));
      CHECK(b.yaw_deg == Approx(a.yaw_deg).margin(0.005));
      CHECK(b.box_count == a.box_count);
      CHECK(b.first_box == a.first_box);
      CHECK(b.pick_index == a.pick_index);
    }
    REQUIRE(out.record.boxes.size() == 5);
    for (std::size_t i = 0; i < 5; ++i) CHECK(out.record.boxes[i].pick_status == in.boxes[i].pick_status);
    // A new result written between two reads shows as ids that disagree.
    RegisterImage torn = image;
    torn[kPickIdCopy] = 78;
    CHECK_FALSE(decode_result(torn, order).ids_agree());
  }
}

TEST_CASE("a result without a gripper leaves 540..902 zero except the result ids",
          "[modbus][register_map]") {
  RegisterImage image{};
  encode_result(make_picking_result(), 5, WordOrder::kHighWordFirst, image);
  ResultRecord plain = make_picking_result();
  plain.picking = false;  // groups and statuses without the flag are not encoded
  encode_result(plain, 6, WordOrder::kHighWordFirst, image);
  CHECK(image[kRegPickResultId] == 6);
  CHECK(image[kPickIdCopy] == 6);
  for (std::uint16_t a = kRegBestRecipe + 1; a < kPickIdCopy; ++a) {
    if (a == kRegPickResultId) continue;
    INFO("register " << a);
    CHECK(image[a] == 0);
  }
  const DecodedResult out = decode_result(image, WordOrder::kHighWordFirst);
  CHECK(out.ids_agree());
  CHECK_FALSE(out.record.picking);
  CHECK(out.record.groups.empty());

  // A failed result has nothing to pick even when its record still carries picks.
  ResultRecord failed = make_picking_result();
  failed.status = ResultStatus::kFailed;
  failed.boxes.clear();
  encode_result(failed, 7, WordOrder::kHighWordFirst, image);
  CHECK(image[kRegPickFlags] == 0);
  CHECK(image[kRegGroupsFound] == 0);
  CHECK(image[kRegPickableBoxes] == 0);
  CHECK(image[kPickIdCopy] == 7);
}

TEST_CASE("groups beyond the 32 reported box slots are counted but not reported",
          "[modbus][register_map]") {
  // 40 boxes in pairs: pairs 0..15 lie in slots 0..31, pairs 16..19 beyond.
  ResultRecord pairs = make_result(40);
  pairs.picking = true;
  for (std::uint16_t g = 0; g < 20; ++g)
    pairs.groups.push_back(make_group(static_cast<std::uint16_t>(2 * g), 2, static_cast<std::uint16_t>(g + 1)));
  pairs.groups_found = 20;
  RegisterImage image{};
  encode_result(pairs, 3, WordOrder::kLowWordFirst, image);
  CHECK(image[kRegGroupsFound] == 20);
  CHECK(image[kRegGroupsReported] == 16);
  CHECK(image[kGroupStart + kGroupStride * 15 + 8] == 30);  // the last group: slots 30-31
  for (std::uint16_t a = kGroupStart + kGroupStride * 16; a < kPickStatusStart; ++a) CHECK(image[a] == 0);
  CHECK(decode_result(image, WordOrder::kLowWordFirst).record.groups.size() == 16);

  // A group that starts in slot 31 but takes slot 32 too is not reported either: the PLC could
  // not find all of its boxes.
  ResultRecord straddling = make_result(40);
  straddling.picking = true;
  straddling.groups = {make_group(0, 1, 1), make_group(31, 2, 2), make_group(33, 1, 3)};
  straddling.groups_found = 3;
  encode_result(straddling, 4, WordOrder::kLowWordFirst, image);
  CHECK(image[kRegGroupsFound] == 3);
  CHECK(image[kRegGroupsReported] == 1);

  // One box per pick: at most 32 groups, one per reported slot.
  ResultRecord singles = make_result(40);
  singles.picking = true;
  for (std::uint16_t g = 0; g < 40; ++g)
    singles.groups.push_back(make_group(g, 1, static_cast<std::uint16_t>(g + 1)));
  encode_result(singles, 5, WordOrder::kLowWordFirst, image);
  CHECK(image[kRegGroupsFound] == 40);  // groups_found 0 counts the groups given
  CHECK(image[kRegGroupsReported] == kMaxGroups);
  CHECK(image[kGroupStart + kGroupStride * 31 + 8] == 31);
  CHECK(image[kPickIdCopy] == 5);
}

TEST_CASE("clear_result clears the pick block", "[modbus][register_map]") {
  RegisterImage image{};
  encode_result(make_picking_result(), 9, WordOrder::kHighWordFirst, image);
  REQUIRE(image[kRegPickFlags] == kPickGripper);
  clear_result(image);
  for (std::size_t a = kResultStart; a < kRegisterCount; ++a) {
    INFO("register " << a);
    CHECK(image[a] == 0);
  }
  CHECK_FALSE(decode_result(image, WordOrder::kHighWordFirst).record.picking);
}
