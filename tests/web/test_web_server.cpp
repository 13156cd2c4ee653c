// The status page server over loopback with httplib's client, fed by a real detection.
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "palletd/frames/frame_io.hpp"
#include "palletd/results/detection_json.hpp"
#include "palletd/web/web.hpp"

#include "web_fixture.hpp"
#include "web_server_helpers.hpp"

// After Eigen: httplib.h pulls in <resolv.h>, whose _res macro breaks Eigen's headers.
#include <httplib.h>

using namespace palletd;
using namespace palletd::testing;
using Json = nlohmann::json;

TEST_CASE("the fixture's detection finds the boxes of the frame") {
  const auto& s = shared_fixture().first();
  INFO(s.detection.message);
  REQUIRE(s.detection.status == DetectionStatus::kOk);
  REQUIRE(s.detection.boxes.size() >= 6);
  for (const auto& b : s.detection.boxes) REQUIRE(b.base_position.has_value());
}

TEST_CASE("the page is self-contained HTML that refreshes itself") {
  WebOptions o = test_options();
  o.refresh_ms = 750;
  Running run(shared_fixture(), o);
  CHECK(WebOptions{}.bind_address == "127.0.0.1");
  auto r = run.client.Get("/");
  REQUIRE(r);
  CHECK(r->status == 200);
  CHECK(r->get_header_value("Content-Type") == "text/html; charset=utf-8");
  CHECK(r->get_header_value("Content-Security-Policy").find("default-src 'self'") != std::string::npos);
  const std::string& html = r->body;
  CHECK(html.find("<table id=\"boxes\"") != std::string::npos);
  CHECK(html.find("id=\"overlay\"") != std::string::npos);
  CHECK(html.find("/api/status") != std::string::npos);
  CHECK(html.find("const REFRESH_MS = 750;") != std::string::npos);
  CHECK(html.find("__REFRESH_MS__") == std::string::npos);
  // No CDN or other outside resource: the cell PC has no internet.
  CHECK(html.find("src=\"http") == std::string::npos);
  CHECK(html.find("href=\"http") == std::string::npos);
  CHECK(html.find("<link") == std::string::npos);
}

TEST_CASE("/api/status reports state, counters, camera, recipe and the decoded registers") {
  testing::WebFixture& f = shared_fixture();
  Running run(f, test_options());
  const Json j = get_json(run.client, "/api/status");
  CHECK(j["status"]["state"] == "ready");
  CHECK(j["status"]["error_code"] == 0);
  REQUIRE(j["status"]["bits"].size() == 11);
  CHECK(j["status"]["bits"][10]["name"] == "DriftWarning");
  CHECK(j["status"]["bits"][0]["name"] == "Ready");
  CHECK(j["status"]["bits"][0]["set"] == true);
  CHECK(j["status"]["bits"][1]["set"] == false);  // Busy
  CHECK(j["status"]["bits"][3]["name"] == "ResultReady");
  CHECK(j["status"]["bits"][3]["set"] == true);
  CHECK(j["status"]["bits"][6]["set"] == true);  // CameraOK
  CHECK(j["status"]["poses_in"] == "base");
  CHECK(j["camera"]["id"] == "synthetic-0001");
  CHECK(j["camera"]["ok"] == true);
  CHECK(j["counters"]["triggers"] == 7);
  CHECK(j["counters"]["missed"] == 3);
  CHECK(j["counters"]["reconnects"] == 2);
  CHECK(j["counters"]["grab_timeouts"] == 5);
  CHECK(j["counters"]["latency_ms"]["p50"] == Approx(85.0));
  CHECK(j["recipe"]["number"] == 1);
  CHECK(j["recipe"]["name"] == "mixed 315/400");
  REQUIRE(j["recipe"]["formats"].size() == 2);
  CHECK(j["recipe"]["formats"][1]["long_mm"] == Approx(400.0));
  CHECK(j["last_result"]["trigger_seq"] == 7);
  CHECK(j["last_result"]["boxes"] == f.first().detection.boxes.size());

  const Json& regs = j["registers"];
  REQUIRE(regs["blocks"].size() == 5);
  const Json& health = regs["blocks"][4];
  CHECK(health["name"] == "health");
  REQUIRE(health["rows"].size() == 8);
  CHECK(health["rows"][0]["address"] == "146");
  CHECK(health["rows"][0]["meaning"] == "drift; reference loaded; drift measured");
  CHECK(health["rows"][2]["value"] == "4.0 %");
  CHECK(health["rows"][6]["value"] == "12.5 mm");
  CHECK(j["cell_health"]["frames"] == 7);
  CHECK(j["cell_health"]["invalid_fraction"] == Approx(0.04));
  CHECK(j["cell_health"]["flying_fraction"].is_null());
  CHECK(j["cell_health"]["warnings"] == Json::array({"drift"}));
  CHECK(j["cell_health"]["drift"]["shift_mm"] == Approx(12.5));
  const Json& connections = regs["blocks"][3];
  CHECK(connections["name"] == "connections");
  REQUIRE(connections["rows"].size() == 4);
  CHECK(connections["rows"][0]["address"] == "140-141");
  CHECK(connections["rows"][3]["address"] == "145");
  CHECK(connections["rows"][3]["name"] == "connection cap");
  const Json& status_rows = regs["blocks"][1]["rows"];
  REQUIRE(status_rows.size() == 22);  // 100..129: 16 rows, then the six camera fault counters
  CHECK(status_rows[0]["address"] == "100");
  CHECK(status_rows[0]["ref"] == "40101");
  CHECK(status_rows[0]["meaning"] == "Ready, ResultReady, CameraOK");
  bool pattern_ok = false;
  for (const auto& row : status_rows)
    if (row["name"] == "test pattern") pattern_ok = row["value"] == "0x12345678" && row["address"] == "110-111";
  CHECK(pattern_ok);
  bool resent_ok = false, timeouts_ok = false;
  for (const auto& row : status_rows) {
    if (row["name"] == "resent packets") resent_ok = row["value"] == "70000" && row["address"] == "128-129";
    if (row["name"] == "grab timeouts") timeouts_ok = row["value"] == "5" && row["address"] == "120-121";
  }
  CHECK(resent_ok);
  CHECK(timeouts_ok);
  CHECK(regs["blocks"][0]["rows"][0]["meaning"] == "ResultAck");
  REQUIRE(regs["boxes"].size() == f.first().detection.boxes.size());
  CHECK(regs["boxes"][0]["address"] == 210);
  CHECK(regs["boxes"][1]["ref"] == "40221-40230");
}

TEST_CASE("/api/status puts an error code and its detail into words") {
  testing::WebFixture f;
  modbus::RegisterImage image = f.encode(f.first(), modbus::kStReady | modbus::kStError);
  image[modbus::kRegErrorCode] = static_cast<std::uint16_t>(modbus::ErrorCode::kDetectionFailed);
  image[modbus::kRegErrorDetail] = static_cast<std::uint16_t>(modbus::DetectionFailure::kNoPlane);
  f.set_registers(image);
  Running run(f, test_options());
  const Json j = get_json(run.client, "/api/status");
  CHECK(j["status"]["state"] == "error");
  CHECK(j["status"]["error"] == "detection failed");
  CHECK(j["status"]["error_text"].get<std::string>().find("no plane") != std::string::npos);
  CHECK(j["registers"]["blocks"][1]["rows"][1]["meaning"] == "detection failed");

  image[modbus::kRegErrorCode] = static_cast<std::uint16_t>(modbus::ErrorCode::kUnknownRecipe);
  image[modbus::kRegErrorDetail] = 9;
  f.set_registers(image);
  const Json k = get_json(run.client, "/api/status");
  CHECK(k["status"]["error_text"].get<std::string>().find("recipe 9") != std::string::npos);
}

TEST_CASE("/api/status shows the result extension: why no boxes, height above the pallet, layers left") {
  testing::WebFixture f;
  modbus::RegisterImage image = f.encode(f.first(), modbus::kStReady);
  image[modbus::kRegResultDetail] = static_cast<std::uint16_t>(modbus::ResultDetail::kSlipSheet);
  image[modbus::kRegLayerInfoFlags] = modbus::kLayerHeightKnown | modbus::kLayersRemainingKnown;
  modbus::put_i32(&image[modbus::kRegHeightAbovePallet], 7500, modbus::WordOrder::kHighWordFirst);
  image[modbus::kRegLayersRemaining] = 3;
  f.set_registers(image);
  Running run(f, test_options());
  const Json j = get_json(run.client, "/api/status");
  std::map<std::string, Json> rows;
  for (const auto& row : j["registers"]["blocks"][2]["rows"]) rows[row["name"].get<std::string>()] = row;
  REQUIRE(rows.count("result detail") == 1);
  CHECK(rows["result detail"]["address"] == "130");
  CHECK(rows["result detail"]["meaning"] == "slip sheet: remove it");
  CHECK(rows["height above pallet"]["value"] == "750.0 mm");
  CHECK(rows["layers left"]["value"] == "3");
}

TEST_CASE("/api/result is the detection line of the spec plus trigger metadata") {
  testing::WebFixture& f = shared_fixture();
  Running run(f, test_options());
  auto r = run.client.Get("/api/result");
  REQUIRE(r);
  REQUIRE(r->status == 200);
  CHECK(r->get_header_value("Content-Type") == "application/json");
  // Any reader of shared/spec/detections.md reads it.
  Expected<ParsedDetection> parsed = parse_detection_line(r->body);
  INFO(parsed.error());
  REQUIRE(parsed.ok());
  CHECK(parsed->status == "ok");
  REQUIRE(parsed->boxes.size() == f.first().detection.boxes.size());
  CHECK(parsed->frame == "palletd-synthetic-0001-7");

  const Json j = Json::parse(r->body);
  CHECK(j["trigger"]["seq"] == 7);
  CHECK(j["trigger"]["request_id"] == 1234);
  CHECK(j["trigger"]["recipe"] == 1);
  CHECK(j["trigger"]["latency_ms"] == Approx(85.0));
  CHECK(j["trigger"]["error"] == "no error");
  CHECK(j["poses_in"] == "base");
  REQUIRE(j["table"].size() == f.first().detection.boxes.size());
  for (std::size_t i = 0; i < j["table"].size(); ++i) {
    const auto& row = j["table"][i];
    const auto& box = f.first().detection.boxes[i];
    CHECK(row["frame"] == "base");
    CHECK(row["x_mm"].get<double>() == Approx(box.base_position->x() * 1000.0));
    CHECK(row["yaw_deg"].get<double>() == Approx(*box.base_yaw_deg));
    CHECK(row["format_name"] == (box.format == 0 ? "F315" : "F400"));
    CHECK(j["boxes"][i]["base"]["position"][2].get<double>() == Approx(box.base_position->z()));
    // The score's evidence, shown on hover.
    CHECK(row["score"].get<double>() == Approx(box.score));
    CHECK(row["score_terms"]["position_sigma_mm"].get<double>() == Approx(box.score_terms.position_sigma_mm));
    CHECK(row["score_terms"]["contested"] == box.score_terms.contested);
  }
  CHECK(j["layout_confidence"].get<double>() == Approx(f.first().detection.layout_confidence));
}

TEST_CASE("without camera_to_base the box table is in the camera frame and says so") {
  testing::WebFixture& f = shared_fixture();
  auto s = std::make_shared<ResultSnapshot>(f.first());
  for (auto& b : s->detection.boxes) b.base_position.reset(), b.base_yaw_deg.reset();
  testing::WebFixture local;
  local.set_latest(s);
  Running run(local, test_options());
  const Json j = get_json(run.client, "/api/result");
  CHECK(j["poses_in"] == "camera");
  REQUIRE(!j["table"].empty());
  CHECK(j["table"][0]["frame"] == "camera");
  CHECK(j["table"][0]["z_mm"].get<double>() == Approx(s->detection.boxes[0].center.z() * 1000.0));
  CHECK(j["table"][0]["pickable"].is_null());  // no gripper
  CHECK(j["table"][0]["blocked_by"] == "");
}

TEST_CASE("with a gripper the box table says which boxes the robot can take now, and why not") {
  testing::WebFixture& f = shared_fixture();
  auto s = std::make_shared<ResultSnapshot>(f.first());
  REQUIRE(s->detection.boxes.size() >= 2);
  s->detection.boxes[0].pick = BoxPick{true, PickBlock::kNone, TcpPose{}};
  s->detection.boxes[1].pick = BoxPick{false, PickBlock::kHigherLevel, TcpPose{}};
  testing::WebFixture local;
  local.set_latest(s);
  Running run(local, test_options());
  const Json j = get_json(run.client, "/api/result");
  CHECK(j["table"][0]["pickable"] == true);
  CHECK(j["table"][0]["blocked_by"] == "");
  CHECK(j["table"][1]["pickable"] == false);
  CHECK(j["table"][1]["blocked_by"] == "higher_level");
  CHECK(j["check"].is_null());  // a detection's result
}

TEST_CASE("a result that answers a pick check carries the verdict and each checked box in /api/result") {
  testing::WebFixture& f = shared_fixture();
  auto s = std::make_shared<ResultSnapshot>(f.first());
  PickCheck check;
  check.verdict = PickVerdict::kNeighbourMoved;
  check.message = "box 2 moved 21.0 mm";
  check.boxes.resize(3);
  check.boxes[0].picked = true;
  check.boxes[2].present = check.boxes[2].moved = true;
  check.boxes[2].box = 2;
  check.boxes[2].shift_mm = 21.0;
  s->check = check;
  testing::WebFixture local;
  local.set_latest(s);
  Running run(local, test_options());
  const Json j = get_json(run.client, "/api/result");
  REQUIRE(j["check"].is_object());
  CHECK(j["check"]["verdict"] == "neighbour_moved");
  CHECK(j["check"]["message"] == check.message);
  REQUIRE(j["check"]["boxes"].size() == 3);
  CHECK(j["check"]["boxes"][0]["picked"] == true);
  CHECK(j["check"]["boxes"][0]["present"] == false);
  CHECK(j["check"]["boxes"][2]["moved"] == true);
  CHECK(j["check"]["boxes"][2]["shift_mm"].get<double>() == Approx(21.0));
}

TEST_CASE("/api/overlay.png is the overlay of the latest snapshot, rendered once") {
  testing::WebFixture& f = shared_fixture();
  Running run(f, test_options());
  auto a = run.client.Get("/api/overlay.png");
  REQUIRE(a);
  REQUIRE(a->status == 200);
  CHECK(a->get_header_value("Content-Type") == "image/png");
  std::vector<std::uint8_t> bytes(a->body.begin(), a->body.end());
  const cv::Mat img = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  REQUIRE(!img.empty());
  CHECK(img.cols >= f.first().frame->intrinsics.width);
  CHECK(img.channels() == 3);
  auto b = run.client.Get("/api/overlay.png?seq=7");
  REQUIRE(b);
  CHECK(b->body == a->body);
}

TEST_CASE("the last frame downloads in the frame format and reads back identical") {
  testing::WebFixture& f = shared_fixture();
  Running run(f, test_options());
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("palletd-web-test-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string stem = (dir / "palletd-synthetic-0001-7").string();
  auto save = [&](const std::string& path, const std::string& suffix, const std::string& type) {
    auto r = run.client.Get(path.c_str());
    REQUIRE(r);
    REQUIRE(r->status == 200);
    CHECK(r->get_header_value("Content-Type") == type);
    CHECK(r->get_header_value("Content-Disposition") ==
          "attachment; filename=\"palletd-synthetic-0001-7" + suffix + "\"");
    std::ofstream(stem + suffix, std::ios::binary) << r->body;
  };
  save("/api/frame/depth.png", ".depth.png", "image/png");
  save("/api/frame/meta.json", ".json", "application/json");
  save("/api/frame/detection.json", ".detection.json", "application/json");
  Expected<Frame> back = read_frame(stem);
  INFO(back.error());
  REQUIRE(back.ok());
  const Frame& orig = *f.first().frame;
  CHECK(back->intrinsics.width == orig.intrinsics.width);
  CHECK(back->intrinsics.fx == Approx(orig.intrinsics.fx));
  CHECK(back->depth == orig.depth);
  CHECK(back->depth_scale_m == Approx(orig.depth_scale_m));
  REQUIRE(back->T_base_camera.has_value());
  CHECK(back->T_base_camera->matrix().isApprox(orig.T_base_camera->matrix(), 1e-9));
  // The detection line of the same frame, as the recorder stores it.
  std::ifstream in(stem + ".detection.json");
  std::string line;
  std::getline(in, line);
  Expected<ParsedDetection> parsed = parse_detection_line(line);
  REQUIRE(parsed.ok());
  CHECK(parsed->boxes.size() == f.first().detection.boxes.size());
  fs::remove_all(dir);
}
