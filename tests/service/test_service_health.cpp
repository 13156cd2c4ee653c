// Cell health and camera drift end to end: simulated cell frames replayed by the camera driver, the
// drift reference set with control bit 4 over a real Modbus TCP client, and the health block
// 146..155 and status word bits 9 and 10 read back after triggers.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <thread>

#include <catch2/catch.hpp>
#include <unistd.h>

#include "palletd/config/config.hpp"
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
                 ("palletd-health-" + std::to_string(::getpid()) + "-" +
                  std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  TempDir() { fs::create_directories(dir / "replay"); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

/// A cell (cabinet, posts) seen by a small time-of-flight camera; `turn_deg` turns the camera
/// about its x axis as a knocked bracket would, while the frame keeps the calibration it had.
Frame cell_frame(const sim::Scene& scene, std::uint64_t seed, double turn_deg) {
  const sim::SensorProfile profile = *sim::profile_by_name("o3d303");
  sim::Scene moved = scene;
  moved.T_world_camera =
      scene.T_world_camera * Eigen::AngleAxisd(turn_deg * M_PI / 180.0, Eigen::Vector3d::UnitX());
  Frame frame = sim::render(moved, profile, seed).frame;
  frame.T_base_camera = scene.T_world_camera;
  return frame;
}

std::uint16_t read_reg(modbus::PlcClient& plc, std::uint16_t address) {
  modbus::RegisterImage image{};
  REQUIRE(plc.read(address, 1, image).ok());
  return image[address];
}

/// Waits until register `address` satisfies `ok` (the health block follows the result by a few ms).
template <typename Ok>
std::uint16_t wait_reg(modbus::PlcClient& plc, std::uint16_t address, Ok ok) {
  std::uint16_t v = read_reg(plc, address);
  for (int i = 0; i < 200 && !ok(v); ++i) {
    std::this_thread::sleep_for(20ms);
    v = read_reg(plc, address);
  }
  return v;
}

}  // namespace

TEST_CASE("drift: control bit 4 sets the reference, a knocked camera raises DriftWarning",
          "[health][drift]") {
  TempDir tmp;
  sim::ScenarioOptions options;
  options.scene = sim::SceneFamily::kCell;
  const sim::SensorProfile profile = *sim::profile_by_name("o3d303");
  const Expected<sim::Scene> scene = sim::make_scene(options, profile, 11);
  REQUIRE(scene);
  REQUIRE(scene->has_roi);
  // Replayed in name order: the reference, the same cell again, the camera turned by 1 degree.
  REQUIRE(write_frame((tmp.dir / "replay/0000").string(), cell_frame(*scene, 1, 0.0)).ok());
  REQUIRE(write_frame((tmp.dir / "replay/0001").string(), cell_frame(*scene, 2, 0.0)).ok());
  REQUIRE(write_frame((tmp.dir / "replay/0002").string(), cell_frame(*scene, 3, 1.0)).ok());

  Config config = load_config(std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml");
  config.camera.driver = "replay";
  config.camera.replay.directory = (tmp.dir / "replay").string();
  config.camera.replay.rate_hz = 0.0;  // one frame per request, in name order
  config.modbus.bind_address = "127.0.0.1";
  config.modbus.port = 0;
  config.recording.enabled = false;
  RegionOfInterest roi;
  roi.min_m = scene->roi_min_m;
  roi.max_m = scene->roi_max_m;
  config.detection.roi = roi;
  config.health.drift_reference = (tmp.dir / "reference/drift").string();
  Service service(config);
  REQUIRE(service.start().ok());
  CHECK_FALSE(service.health().cell_health.drift_reference);  // no file yet

  modbus::PlcClient plc("127.0.0.1", service.health().modbus_port, config.modbus.unit_id);
  REQUIRE(plc.connect().ok());
  const std::uint16_t set = modbus::kCtlSetDriftReference, clear = 0;
  REQUIRE(plc.write(modbus::kRegControlWord, &set, 1).ok());
  const std::uint16_t loaded = wait_reg(
      plc, modbus::kRegHealthFlags, [](std::uint16_t v) { return (v & modbus::kHealthDriftReference) != 0; });
  CHECK((loaded & modbus::kHealthDriftReference) != 0);
  CHECK(fs::exists(tmp.dir / "reference/drift.depth.png"));
  REQUIRE(plc.write(modbus::kRegControlWord, &clear, 1).ok());

  const auto recipe = static_cast<std::uint16_t>(config.recipes.front().number);
  REQUIRE(plc.trigger(recipe, 1, 20s).ok());
  wait_reg(plc, modbus::kRegHealthFrames, [](std::uint16_t v) { return v >= 1; });
  CellHealth h = service.health().cell_health;
  CAPTURE(h.drift_note, h.drift_shift_mm, h.drift_angle_deg);
  REQUIRE(h.drift_measured);
  CHECK(h.drift_angle_deg < 0.1);
  CHECK((read_reg(plc, modbus::kRegStatusWord) & modbus::kStDriftWarning) == 0);
  REQUIRE(h.invalid_fraction);
  CHECK(read_reg(plc, modbus::kRegInvalidPermille) == modbus::unit_to_permille(*h.invalid_fraction));

  REQUIRE(plc.trigger(recipe, 2, 20s).ok());
  const std::uint16_t word = wait_reg(plc, modbus::kRegStatusWord,
                                      [](std::uint16_t v) { return (v & modbus::kStDriftWarning) != 0; });
  h = service.health().cell_health;
  CAPTURE(h.drift_note, h.drift_shift_mm, h.drift_angle_deg);
  CHECK((word & modbus::kStDriftWarning) != 0);
  CHECK((word & modbus::kStError) == 0);  // a warning: the result still stands
  CHECK(h.drift_angle_deg == Approx(1.0).margin(0.15));
  CHECK(read_reg(plc, modbus::kRegDriftAngle) == Approx(100).margin(15));
  CHECK(read_reg(plc, modbus::kRegHealthFrames) == 2);
  service.stop();
}
