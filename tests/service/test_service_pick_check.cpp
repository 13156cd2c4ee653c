// The pick check end to end: a simulated layer picked box by box, the frames replayed by the camera
// driver, the PLC's side done by a real Modbus TCP client over loopback: trigger, take the first
// group, PickCheck with the group's number, read the check (135..139) and the layout after the pick.
#include <chrono>
#include <filesystem>

#include <catch2/catch.hpp>
#include <unistd.h>

#include "palletd/config/config.hpp"
#include "palletd/detection/pick_check.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/service/service.hpp"
#include "palletd/sim/sim.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace palletd;

namespace {

struct TempDir {
  fs::path dir = fs::temp_directory_path() /
                 ("palletd-pickcheck-" + std::to_string(::getpid()) + "-" +
                  std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  TempDir() { fs::create_directories(dir); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

/// A 400x300 block layer under a small time-of-flight camera, with the config that detects it.
struct Cell {
  sim::SensorProfile profile = *sim::profile_by_name("helios2");
  sim::Scene scene;
  Config config;
  std::vector<BoxFormat> formats;

  Cell(const fs::path& replay, std::uint64_t seed) {
    sim::ScenarioOptions o;
    o.pattern = sim::PatternFamily::kBlock;
    o.formats = {*sim::parse_format("400x300x250")};
    o.tilt_max_deg = 5.0;
    o.height_min_m = 1.6;
    o.height_max_m = 1.9;
    scene = *sim::make_scene(o, profile, seed);
    for (const auto& r : scene.recipe) formats.push_back(BoxFormat{r.long_m, r.short_m, r.name, 0.0});
    config.formats = formats;
    config.recipes = {Recipe{1, "block", {0}}};
    config.camera.driver = "replay";
    config.camera.replay.directory = replay.string();
    config.camera.replay.rate_hz = 0.0;
    config.camera.replay.loop = false;
    config.camera.frame_timeout_ms = 3000;
    config.modbus.bind_address = "127.0.0.1";
    config.modbus.port = 0;
    config.recording.enabled = false;
    GripperParams gripper;
    gripper.footprint_mm = Eigen::Vector2d(380.0, 280.0);
    config.detection.gripper = gripper;
  }

  /// Renders `s`, writes it as replay frame `index` and returns the frame as read back.
  Frame write(const sim::Scene& s, const fs::path& replay, int index, std::uint64_t seed) const {
    const std::string stem = (replay / ("frame_" + std::to_string(index))).string();
    REQUIRE(write_frame(stem, sim::render(s, profile, seed).frame).ok());
    Expected<Frame> back = read_frame(stem);
    REQUIRE(back.ok());
    return std::move(back).value();
  }
};

/// Index into scene.boxes of the built box under a detected box.
std::size_t scene_box(const sim::Scene& scene, const DetectedBox& box) {
  const Eigen::Vector2d at = box.base_position->head<2>();
  return *std::min_element(scene.top_layer.begin(), scene.top_layer.end(), [&](std::size_t a, std::size_t b) {
    return (scene.boxes[a].center - at).norm() < (scene.boxes[b].center - at).norm();
  });
}

void remove_box(sim::Scene& scene, std::size_t k) {
  scene.boxes[k].top_z_m = -1.0;
  scene.boxes[k].bottom_z_m = -1.3;
}

/// The standing box nearest to box `k` of the scene's top layer.
std::size_t nearest_standing(const sim::Scene& scene, std::size_t k) {
  std::size_t best = k;
  double best_d = 1e9;
  for (const std::size_t j : scene.top_layer) {
    if (j == k || scene.boxes[j].top_z_m < 0.0) continue;
    const double d = (scene.boxes[j].center - scene.boxes[k].center).norm();
    if (d < best_d) best_d = d, best = j;
  }
  return best;
}

}  // namespace

TEST_CASE("pick check over Modbus: a clean pick, then a dragged neighbour with its new pose",
          "[pick_check]") {
  TempDir tmp;
  Cell cell(tmp.dir, 8123);
  // Frame 0: the layer. Detected here the same way the daemon will, to know its first pick.
  const Frame f0 = cell.write(cell.scene, tmp.dir, 0, 11);
  const Detection d0 = detect(f0, cell.formats, cell.config.detection);
  REQUIRE(d0.status == DetectionStatus::kOk);
  REQUIRE(d0.boxes.size() == cell.scene.top_layer.size());
  REQUIRE_FALSE(d0.groups.empty());
  // Frame 1: the first group's box taken. Frame 2: the next group's box taken too, and the robot
  // dragged that box's nearest neighbour 20 mm along x.
  sim::Scene s1 = cell.scene;
  const std::size_t first = scene_box(s1, d0.boxes[static_cast<std::size_t>(d0.groups[0].boxes.front())]);
  remove_box(s1, first);
  const Frame f1 = cell.write(s1, tmp.dir, 1, 12);
  const PickCheck c1 = check_pick(f0, d0, f1, d0.groups[0].boxes, cell.config.check);
  REQUIRE(c1.verdict == PickVerdict::kPickOk);
  const Detection d1 = after_pick(d0, c1, f1, cell.config.detection);
  REQUIRE_FALSE(d1.groups.empty());
  sim::Scene s2 = s1;
  const std::size_t second = scene_box(s2, d1.boxes[static_cast<std::size_t>(d1.groups[0].boxes.front())]);
  remove_box(s2, second);
  const std::size_t dragged = nearest_standing(s2, second);
  s2.boxes[dragged].center.x() += 0.020;
  cell.write(s2, tmp.dir, 2, 13);

  Service service(cell.config);
  REQUIRE(service.start().ok());
  modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, cell.config.modbus.unit_id);
  REQUIRE(plc.connect().ok());

  SECTION("a PickCheck before any result, or naming nothing, fails with error 8 and keeps no boxes") {
    auto early = plc.pick_check(1, 0, 5, 10s);
    REQUIRE(early.ok());
    CHECK(early->status.error == modbus::ErrorCode::kPickCheckFailed);
    CHECK(early->status.error_detail == static_cast<std::uint16_t>(modbus::PickCheckFailure::kNoLayout));
    auto detected = plc.trigger(1, 6, 10s);
    REQUIRE(detected.ok());
    auto nothing = plc.pick_check(0, 0, 7, 10s);
    REQUIRE(nothing.ok());
    CHECK(nothing->status.error == modbus::ErrorCode::kPickCheckFailed);
    CHECK(nothing->status.error_detail ==
          static_cast<std::uint16_t>(modbus::PickCheckFailure::kNothingPicked));
    CHECK(nothing->result.record.status == modbus::ResultStatus::kFailed);
    CHECK(nothing->result.record.boxes.empty());
  }

  SECTION("pick, check, pick, check") {
    auto detected = plc.trigger(1, 10, 10s);
    REQUIRE(detected.ok());
    const modbus::ResultRecord& r0 = detected->result.record;
    REQUIRE(r0.boxes.size() == d0.boxes.size());
    CHECK_FALSE(r0.check.has_value());  // 135 = 0 on a detection's result

    auto checked = plc.pick_check(0, 1, 11, 10s);  // the first group
    REQUIRE(checked.ok());
    REQUIRE(checked->result.ids_agree());
    const modbus::ResultRecord& r1 = checked->result.record;
    CHECK(checked->status.error == modbus::ErrorCode::kNone);
    CHECK(r1.request_id == 11);
    CHECK(r1.recipe == 1);
    REQUIRE(r1.check.has_value());
    CHECK(r1.check->result == modbus::CheckResult::kPickOk);
    CHECK(r1.check->boxes_gone == 1);
    CHECK(r1.check->boxes_moved == 0);
    CHECK(r1.boxes.size() == d0.boxes.size() - 1);
    CHECK(r1.picking);
    CHECK(r1.groups.size() == d1.groups.size());
    const auto snap1 = service.latest();
    REQUIRE(snap1 != nullptr);
    REQUIRE(snap1->check.has_value());
    CHECK(snap1->check->verdict == PickVerdict::kPickOk);

    auto dragged_check = plc.pick_check(0, 1, 12, 10s);
    REQUIRE(dragged_check.ok());
    const modbus::ResultRecord& r2 = dragged_check->result.record;
    REQUIRE(r2.check.has_value());
    CHECK(r2.check->result == modbus::CheckResult::kNeighbourMoved);
    CHECK(r2.check->boxes_gone == 1);
    REQUIRE(r2.check->boxes_moved >= 1);
    REQUIRE(r2.check->moved_slot >= 1);
    CHECK(r2.check->largest_move_m == Approx(0.020).margin(0.006));
    CHECK(r2.boxes.size() == d0.boxes.size() - 2);
    // The moved box's slot holds its new pose: where the robot left it, within a few millimetres.
    const modbus::BoxRecord& moved = r2.boxes[r2.check->moved_slot - 1u];
    const Eigen::Vector2d truth = s2.boxes[dragged].center;
    CAPTURE(moved.x_m, moved.y_m, truth.x(), truth.y());
    CHECK((Eigen::Vector2d(moved.x_m, moved.y_m) - truth).norm() < 0.006);
  }
  service.stop();
}
