// The pick check end to end: a simulated layer picked box by box until it is gone, the frames
// replayed by the camera driver, the PLC's side done by a real Modbus TCP client over loopback:
// trigger, take the first group, PickCheck with the group's number, read the check (135..139) and
// the layout after the pick, and at the end trigger for the next level.
#include <chrono>
#include <cstdio>
#include <filesystem>

#include <catch2/catch.hpp>
#include <unistd.h>

#include "palletd/config/config.hpp"
#include "palletd/detection/pick_check.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/service/service.hpp"
#include "palletd/sim/pick.hpp"
#include "palletd/sim/sim.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using namespace palletd;

namespace {

struct PickCheckDir {
  fs::path dir = fs::temp_directory_path() /
                 ("palletd-pickcheck-" + std::to_string(::getpid()) + "-" +
                  std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  PickCheckDir() { fs::create_directories(dir); }
  ~PickCheckDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

/// A 600x400 block layer (four cartons on a 1200x800 pallet) under a small time-of-flight camera, with the
/// config that detects it.
struct Cell {
  sim::SensorProfile profile = *sim::profile_by_name("helios2");
  sim::Scene scene;
  Config config;
  std::vector<BoxFormat> formats;

  Cell(const fs::path& replay, std::uint64_t seed) {
    sim::ScenarioOptions o;
    o.pattern = sim::PatternFamily::kBlock;
    o.formats = {*sim::parse_format("600x400x250")};
    o.tilt_max_deg = 5.0;
    o.height_min_m = 1.6;
    o.height_max_m = 1.9;
    scene = *sim::make_scene(o, profile, seed);
    for (const auto& r : scene.recipe) formats.push_back(BoxFormat{r.long_m, r.short_m, r.name, 0.0});
    config.formats = formats;
    config.recipes = {Recipe{1, "block", {0}, std::nullopt}};
    config.camera.driver = "replay";
    config.camera.replay.directory = replay.string();
    config.camera.replay.rate_hz = 0.0;
    config.camera.replay.loop = false;
    config.camera.frame_timeout_ms = 3000;
    config.modbus.bind_address = "127.0.0.1";
    config.modbus.port = 0;
    config.recording.enabled = false;
    GripperParams gripper;
    gripper.footprint_mm = Eigen::Vector2d(560.0, 360.0);
    config.detection.gripper = gripper;
  }

  /// Renders `s`, writes it as replay frame `index` and returns the frame as read back.
  Frame write(const sim::Scene& s, const fs::path& replay, int index, std::uint64_t seed) const {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%03d", index);  // replayed in name order
    const std::string stem = (replay / name).string();
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

/// The standing box nearest to box `k` of the scene's top layer.
std::size_t nearest_standing(const sim::Scene& scene, std::size_t k) {
  std::size_t best = k;
  double best_d = 1e9;
  for (const std::size_t j : scene.top_layer) {
    if (j == k || sim::taken_off(scene.boxes[j])) continue;
    const double d = (scene.boxes[j].center - scene.boxes[k].center).norm();
    if (d < best_d) best_d = d, best = j;
  }
  return best;
}

}  // namespace

TEST_CASE("pick check over Modbus: a layer picked box by box, a dragged neighbour, then the next level",
          "[pick_check]") {
  PickCheckDir tmp;
  Cell cell(tmp.dir, 8123);
  // The frames the replay camera serves, worked out here the way the daemon will: the layer twice
  // (the first detection is spoilt by a check that names nothing); after each pick the layer
  // without the first group's box, the robot dragging the nearest neighbour 20 mm into the gap at
  // the second pick; the layer gone, seen once more for the trigger that finds the next level.
  sim::Scene s = cell.scene;
  cell.write(s, tmp.dir, 0, 100);
  Frame f = cell.write(s, tmp.dir, 1, 100);
  Detection d = detect(f, cell.formats, cell.config.detection);
  REQUIRE(d.status == DetectionStatus::kOk);
  const std::size_t n = d.boxes.size();
  REQUIRE(n == cell.scene.top_layer.size());
  std::size_t dragged = 0;
  std::vector<PickVerdict> verdicts;
  for (std::size_t k = 1; k <= n; ++k) {
    REQUIRE_FALSE(d.groups.empty());
    const std::size_t taken = scene_box(s, d.boxes[static_cast<std::size_t>(d.groups[0].boxes.front())]);
    sim::take_off(s.boxes[taken]);
    if (k == 2) {
      dragged = nearest_standing(s, taken);
      s.boxes[dragged].center += 0.020 * (s.boxes[taken].center - s.boxes[dragged].center).normalized();
    }
    const Frame next = cell.write(s, tmp.dir, static_cast<int>(k + 1), 100 + k);
    const PickCheck c = check_pick(f, d, next, d.groups[0].boxes, cell.config.check);
    verdicts.push_back(c.verdict);
    d = after_pick(d, c, next, cell.config.detection);
    f = next;
  }
  REQUIRE(d.boxes.empty());
  REQUIRE(verdicts[1] == PickVerdict::kNeighbourMoved);
  cell.write(s, tmp.dir, static_cast<int>(n + 2), 300);

  Service service(cell.config);
  REQUIRE(service.start().ok());
  modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, cell.config.modbus.unit_id);
  REQUIRE(plc.connect().ok());
  auto fails_with = [](const modbus::PlcClient::TriggerResult& r, modbus::PickCheckFailure why) {
    CHECK(r.status.error == modbus::ErrorCode::kPickCheckFailed);
    CHECK(r.status.error_detail == static_cast<std::uint16_t>(why));
    CHECK(r.result.record.status == modbus::ResultStatus::kFailed);
    CHECK(r.result.record.boxes.empty());
  };
  auto early = plc.pick_check(1, 0, 5, 10s);  // nothing to check against yet
  REQUIRE(early.ok());
  fails_with(*early, modbus::PickCheckFailure::kNoLayout);
  REQUIRE(plc.trigger(1, 6, 10s).ok());
  auto nothing = plc.pick_check(0, 0, 7, 10s);  // registers 4 and 5 name nothing
  REQUIRE(nothing.ok());
  fails_with(*nothing, modbus::PickCheckFailure::kNothingPicked);

  auto detected = plc.trigger(1, 10, 10s);
  REQUIRE(detected.ok());
  const modbus::ResultRecord r0 = detected->result.record;
  REQUIRE(r0.boxes.size() == n);
  CHECK_FALSE(r0.check.has_value());  // 135 = 0 on a detection's result
  for (std::size_t k = 1; k <= n; ++k) {
    auto checked = plc.pick_check(0, 1, static_cast<std::uint16_t>(10 + k), 10s);  // the first group
    REQUIRE(checked.ok());
    REQUIRE(checked->result.ids_agree());
    const modbus::ResultRecord& r = checked->result.record;
    CAPTURE(k, service.latest()->check->message);
    CHECK(checked->status.error == modbus::ErrorCode::kNone);
    CHECK(r.request_id == 10 + k);
    CHECK(r.recipe == 1);
    REQUIRE(r.check.has_value());
    CHECK(r.check->result == (verdicts[k - 1] == PickVerdict::kNeighbourMoved
                                  ? modbus::CheckResult::kNeighbourMoved
                                  : modbus::CheckResult::kPickOk));
    CHECK(r.check->boxes_gone == 1);
    CHECK(r.boxes.size() == n - k);
    CHECK(r.picking == (k < n));  // pick data while boxes are left
    if (k == 2) {                 // the dragged box's slot holds where the robot left it
      REQUIRE(r.check->moved_slot >= 1);
      CHECK(r.check->largest_move_m == Approx(0.020).margin(0.006));
      const modbus::BoxRecord& moved = r.boxes[r.check->moved_slot - 1u];
      CHECK((Eigen::Vector2d(moved.x_m, moved.y_m) - s.boxes[dragged].center).norm() < 0.006);
    }
    if (k == n) {  // the last box gone: no boxes, "layer picked"
      CHECK(r.status == modbus::ResultStatus::kNoBoxes);
      CHECK(r.detail == modbus::ResultDetail::kLayerPicked);
      CHECK(checked->status.error_detail == static_cast<std::uint16_t>(modbus::ResultDetail::kLayerPicked));
    }
  }
  // A trigger now finds the level below, one carton height lower.
  auto next_level = plc.trigger(1, 30, 10s);
  REQUIRE(next_level.ok());
  CHECK(next_level->result.record.status == modbus::ResultStatus::kOk);
  CHECK_FALSE(next_level->result.record.boxes.empty());
  CHECK(r0.layer_z_m - next_level->result.record.layer_z_m == Approx(0.25).margin(0.02));
  service.stop();
}
