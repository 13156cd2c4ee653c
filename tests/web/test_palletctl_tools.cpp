// palletctl watch against the real ModbusServer (in-process, any free port), and palletctl
// calibrate on a synthetic frame of a plane seen from a known camera pose. Both run the binary.
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>

#include <Eigen/Geometry>

#include "palletd/frames/frame_io.hpp"
#include "palletd/modbus/server.hpp"

using namespace palletd;

namespace {

struct Run {
  int exit_code = -1;
  std::string out;
};

Run run(const std::string& args) {
  const std::string cmd = std::string(PALLETCTL_EXE) + " " + args + " 2>/dev/null";
  Run r;
  FILE* pipe = popen(cmd.c_str(), "r");
  REQUIRE(pipe != nullptr);
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::filesystem::path temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / (name + "-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace

TEST_CASE("palletctl watch prints the status block in words, one line per poll") {
  modbus::ServerOptions o;
  o.port = 0;
  modbus::ModbusServer server(o);
  REQUIRE(server.start().ok());
  auto status = std::make_shared<modbus::ServiceStatus>();
  status->ready = true;
  status->camera_ok = true;
  status->frames_grabbed = 70000;  // needs both words of 115-116
  status->camera_reconnects = 4;
  server.publish_status(status);
  auto result = std::make_shared<modbus::ResultRecord>();
  result->request_id = 77;
  result->recipe = 1;
  result->status = modbus::ResultStatus::kFailed;
  result->error = modbus::ErrorCode::kDetectionFailed;
  result->error_detail = static_cast<std::uint16_t>(modbus::DetectionFailure::kNoLayer);
  server.publish_result(result);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));  // taken over between two passes

  const Run r = run("watch --host 127.0.0.1 --port " + std::to_string(server.port()) + " --count 3 --interval-ms 50");
  INFO(r.out);
  CHECK(r.exit_code == 0);
  std::istringstream lines(r.out);
  int n = 0;
  for (std::string line; std::getline(lines, line);) {
    ++n;
    CHECK(line.find("ERROR | Ready, ResultReady, Error, CameraOK") != std::string::npos);
    CHECK(line.find("error 3 detection failed, detail 2: The detection failed: no top layer found.") !=
          std::string::npos);
    CHECK(line.find("result 1 (request 77, failed, 0 boxes, recipe 1)") != std::string::npos);
    CHECK(line.find("frames 70000") != std::string::npos);
    CHECK(line.find("reconnects 4") != std::string::npos);
  }
  CHECK(n == 3);
  server.stop();
}

TEST_CASE("palletctl watch reports a server that does not answer and fails") {
  modbus::ServerOptions o;
  o.port = 0;
  std::uint16_t port = 0;
  {
    modbus::ModbusServer server(o);
    REQUIRE(server.start().ok());
    port = server.port();
  }  // closed again: nothing listens there now
  const Run r = run("watch --host 127.0.0.1 --port " + std::to_string(port) + " --count 2 --interval-ms 20");
  CHECK(r.exit_code == 1);
  CHECK(r.out.find("no answer") != std::string::npos);
}

namespace {

// A frame of a tilted plane (z = 2.0 m at the centre) seen by a 320x240 pinhole camera.
Frame plane_frame(const Eigen::Vector3d& n_camera, double d) {
  Frame f;
  f.intrinsics = Intrinsics{320, 240, 300.0, 300.0, 159.5, 119.5, std::nullopt};
  f.depth_scale_m = 0.0001;
  f.depth.resize(f.pixel_count());
  for (int v = 0; v < 240; ++v)
    for (int u = 0; u < 320; ++u) {
      const Eigen::Vector3d ray((u - 159.5) / 300.0, (v - 119.5) / 300.0, 1.0);
      const double z = -d / n_camera.dot(ray);  // n . (ray z) + d = 0
      f.depth[static_cast<std::size_t>(v * 320 + u)] = static_cast<std::uint16_t>(std::lround(z / 0.0001));
    }
  f.camera_id = "test-plane";
  return f;
}

}  // namespace

TEST_CASE("palletctl calibrate recovers a known camera_to_base from pixel points on a plane") {
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, -0.05, -1.0).normalized();  // toward the camera
  const double d = 2.0 * -n.z();                                            // z = 2 m on the axis
  const Frame frame = plane_frame(n, d);
  const auto dir = temp_dir("palletd-calibrate");
  const std::string stem = (dir / "plane").string();
  REQUIRE(write_frame(stem, frame).ok());

  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  // camera -> base, the truth
  T.linear() = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(3.0, Eigen::Vector3d::UnitX())).matrix();
  T.translation() = Eigen::Vector3d(0.25, 1.10, 2.40);

  auto point_line = [&](double u, double v) {
    const Eigen::Vector3d ray((u - 159.5) / 300.0, (v - 119.5) / 300.0, 1.0);
    const Eigen::Vector3d c = ray * (-d / n.dot(ray));
    const Eigen::Vector3d b = T * c * 1000.0;  // the robot reports millimetres
    char buf[200];
    std::snprintf(buf, sizeof buf, "%.2f %.2f %.3f %.3f %.3f", u, v, b.x(), b.y(), b.z());
    return std::string(buf);
  };

  auto parse_matrix = [](const std::string& out) {
    const auto at = out.find("camera_to_base: [");
    REQUIRE(at != std::string::npos);
    std::string list = out.substr(at + 17, out.find(']', at) - at - 17);
    for (char& c : list)
      if (c == ',') c = ' ';
    std::istringstream in(list);
    Eigen::Matrix4d m;
    for (int i = 0; i < 16; ++i) in >> m(i / 4, i % 4);
    REQUIRE(!in.fail());
    return m;
  };
  auto rms_of = [](const std::string& out) {
    const auto at = out.find("RMS residual ");
    REQUIRE(at != std::string::npos);
    return std::stod(out.substr(at + 13));
  };

  SECTION("four points from a points file") {
    const std::string points = (dir / "points.txt").string();
    std::ofstream(points) << "# u v X Y Z [mm]\n"
                          << point_line(40.3, 30.7) << "\n"
                          << point_line(280.0, 35.2) << "\n"
                          << point_line(270.6, 200.1) << "\n"
                          << point_line(55.5, 210.0) << "  # near corner\n";
    const Run r = run("calibrate --frame " + stem + " --points " + points);
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    const Eigen::Matrix4d m = parse_matrix(r.out);
    CHECK(m.isApprox(T.matrix(), 1e-3));
    CHECK((m.block<3, 1>(0, 3) - T.translation()).norm() < 0.001);  // < 1 mm
    CHECK(rms_of(r.out) < 0.5);                                     // depth quantised to 0.1 mm
  }
  SECTION("three points with the plane constraint") {
    const Run r = run("calibrate --frame " + stem + " --point '" + point_line(60, 40) + "' --point '" +
                      point_line(260, 50) + "' --point '" + point_line(150, 200) + "'");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    const Eigen::Matrix4d m = parse_matrix(r.out);
    CHECK(m.isApprox(T.matrix(), 1e-3));
    CHECK(rms_of(r.out) < 0.5);
  }
  SECTION("a wrong point shows in its residual") {
    const Run r = run("calibrate --frame " + stem + " --point '" + point_line(40.3, 30.7) + "' --point '" +
                      point_line(280.0, 35.2) + "' --point '" + point_line(55.5, 210.0) + "' --point '" +
                      point_line(150, 120) + "' --point '270.6 200.1 0 0 0'");
    INFO(r.out);
    REQUIRE(r.exit_code == 0);
    CHECK(rms_of(r.out) > 100.0);
  }
  SECTION("fewer than three points or a pixel outside the frame fail") {
    CHECK(run("calibrate --frame " + stem + " --point '" + point_line(40, 30) + "' --point '" + point_line(280, 35) + "'")
              .exit_code != 0);
    CHECK(run("calibrate --frame " + stem + " --point '400 30 1 2 3' --point '" + point_line(280, 35) +
              "' --point '" + point_line(150, 200) + "'")
              .exit_code != 0);
  }
  std::filesystem::remove_all(dir);
}
