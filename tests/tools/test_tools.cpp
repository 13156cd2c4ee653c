// The executables as a user runs them: exit codes and messages of palletd --check-config and
// palletctl info.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include "palletd/frames/frame_io.hpp"

using Catch::Contains;
namespace fs = std::filesystem;

namespace {

const std::string kBin = PALLETD_BINARY_DIR;
const std::string kSource = PALLETD_SOURCE_DIR;

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "palletd-tools-test-XXXXXX").string();
    REQUIRE(::mkdtemp(pattern.data()) != nullptr);
    path_ = pattern;
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  [[nodiscard]] std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string quote(const std::string& s) {
  std::string q = "'";
  for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct Run {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs a built program with arguments; captures stdout, stderr and the exit code.
Run run(const std::string& program, const std::vector<std::string>& args) {
  TempDir dir;
  std::string command = quote(kBin + "/" + program);
  for (const auto& a : args) command += " " + quote(a);
  command += " </dev/null >" + quote(dir.file("out")) + " 2>" + quote(dir.file("err"));
  const int status = std::system(command.c_str());
  Run r;
  REQUIRE(WIFEXITED(status));
  r.exit_code = WEXITSTATUS(status);
  r.out = slurp(dir.file("out"));
  r.err = slurp(dir.file("err"));
  return r;
}

void write(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

/// `camera_to_base: [...]` with the frame's own calibration, as a configuration line.
std::string camera_to_base_of(const std::string& stem) {
  const palletd::Expected<palletd::Frame> frame = palletd::read_frame(stem);
  REQUIRE(frame);
  REQUIRE(frame->T_base_camera);
  std::ostringstream calibration;
  calibration.precision(17);
  calibration << "camera_to_base: [";
  for (int i = 0; i < 16; ++i)
    calibration << (i > 0 ? ", " : "") << frame->T_base_camera->matrix()(i / 4, i % 4);
  calibration << "]\n";
  return calibration.str();
}

/// One o3d303 frame of `scene` in a cell, simulated into dir/cells; its stem (STEM.roi.yaml beside it).
std::string simulate_cell_frame(TempDir& dir, const std::string& scene, const std::string& seed) {
  const std::string out = dir.file("cells");
  const Run sim = run("src/palletctl/palletctl", {"simulate", "--out", out, "-n", "1", "--scene", scene,
                                                  "--profile", "o3d303", "--cell", "--seed", seed});
  REQUIRE(sim.exit_code == 0);
  std::string stem;
  for (const auto& e : fs::directory_iterator(out)) {
    const std::string name = e.path().string();
    if (name.size() > 9 && name.substr(name.size() - 9) == ".roi.yaml")
      stem = name.substr(0, name.size() - 9);
  }
  REQUIRE_FALSE(stem.empty());
  return stem;
}

}  // namespace

TEST_CASE("palletd --version and palletctl --version print the version") {
  const Run d = run("src/palletd/palletd", {"--version"});
  CHECK(d.exit_code == 0);
  CHECK_THAT(d.out, Contains("palletd 0."));
  const Run c = run("src/palletctl/palletctl", {"--version"});
  CHECK(c.exit_code == 0);
  CHECK_THAT(c.out, Contains("palletctl 0."));
}

TEST_CASE("palletd --check-config accepts the shipped configurations") {
  for (const char* name : {"palletd.yaml", "demo.yaml"}) {
    const std::string path = kSource + "/config/" + name;
    const Run r = run("src/palletd/palletd", {"--check-config", path});
    INFO(r.err);
    CHECK(r.exit_code == 0);
    CHECK(r.out == path + ": ok\n");
  }
}

TEST_CASE("palletd --check-config rejects a bad file with exit code 78 and the place") {
  TempDir dir;
  const std::string bad = dir.file("bad.yaml");
  write(bad, "modbus:\n  port: 502\n  unit_id: 300\n");
  const Run r = run("src/palletd/palletd", {"--check-config", bad});
  CHECK(r.exit_code == 78);
  CHECK_THAT(r.err, Contains(bad + ":3:12: modbus.unit_id: must be between 0 and 255"));
  CHECK(r.out.empty());

  const std::string syntax = dir.file("syntax.yaml");
  write(syntax, "camera:\n  driver: [replay\n");
  const Run s = run("src/palletd/palletd", {"--check-config", syntax});
  CHECK(s.exit_code == 78);
  CHECK_THAT(s.err, Contains(syntax + ":") && Contains("YAML syntax error"));

  const Run missing = run("src/palletd/palletd", {"--check-config", dir.file("none.yaml")});
  CHECK(missing.exit_code == 78);
  CHECK_THAT(missing.err, Contains("none.yaml") && Contains("not found"));
}

TEST_CASE("palletd --check-config warns of a recipe whose formats look alike, and accepts it") {
  TempDir dir;
  const std::string file = dir.file("alike.yaml");
  write(file,
        "formats:\n  - {name: small, long_mm: 400, short_mm: 300}\n  - {name: big, long_mm: 420, short_mm: "
        "320}\n"
        "  - {name: euro, long_mm: 600, short_mm: 400}\n"
        "  - {name: twin, long_mm: 400, short_mm: 300}\n"
        "recipes:\n  - {number: 3, name: two sizes, formats: [small, big]}\n"
        "  - {number: 4, name: euro mix, formats: [euro, small]}\n"
        "  - {number: 5, name: two articles, formats: [small, twin]}\n"
        "pipeline: {default_recipe: 3}\n");
  const Run r = run("src/palletd/palletd", {"--check-config", file});
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(r.out == file + ": ok\n");
  CHECK_THAT(
      r.err,
      Contains(file + ": warning: recipe 3 (two sizes): formats 400x300 and 420x320 differ by 20 and 20 mm"));
  CHECK_THAT(r.err, !Contains("recipe 4"));  // one box or two: seams and tape decide that
  // One carton size under two names: not a doubt, the first name is reported.
  CHECK_THAT(r.err,
             Contains("recipe 5 (two articles): formats small and twin are one carton size (400x300)") &&
                 Contains("reported as small"));
  CHECK_THAT(r.err, !Contains("recipe 5 (two articles): formats 400x300 and 400x300 differ"));
}

TEST_CASE("palletd --config refuses a bad file with exit code 78 before starting anything") {
  TempDir dir;
  write(dir.file("bad.yaml"), "logging: {level: loud}\n");
  const Run bad = run("src/palletd/palletd", {"--config", dir.file("bad.yaml")});
  CHECK(bad.exit_code == 78);
  CHECK_THAT(bad.err, Contains("logging.level"));
  const Run both = run("src/palletd/palletd", {"--config", dir.file("bad.yaml"), "--check-config", "x"});
  CHECK(both.exit_code != 0);
  CHECK(both.exit_code != 78);
}

TEST_CASE("palletctl info summarises frames and goes on after a bad one") {
  TempDir dir;
  palletd::Frame frame;
  frame.intrinsics.width = 4;
  frame.intrinsics.height = 2;
  frame.intrinsics.fx = frame.intrinsics.fy = 100.0;
  frame.intrinsics.cx = 1.5;
  frame.intrinsics.cy = 0.5;
  frame.depth_scale_m = 0.00025;
  frame.depth = {0, 4000, 4400, 6000, 0, 0, 5000, 4800};  // 5 of 8 valid, 1.0 .. 1.5 m
  frame.intensity = {1, 2, 3, 4, 5, 6, 7, 8};
  frame.intensity_bits = 8;
  frame.camera_id = "sim-o3d303";
  REQUIRE(palletd::write_frame(dir.file("good"), frame).ok());

  const Run r = run("src/palletctl/palletctl", {"info", dir.file("missing"), dir.file("good")});
  CHECK(r.exit_code == 1);
  std::istringstream lines(r.out);
  std::string first, second;
  std::getline(lines, first);
  std::getline(lines, second);
  CHECK_THAT(first, Contains("missing: error:") && Contains("missing.json"));
  CHECK(second == dir.file("good") +
                      ": 4x2, depth_scale 0.00025 m, valid 62.5 %, depth 1.000..1.500 m, intensity 8-bit, "
                      "camera sim-o3d303");

  const Run ok = run("src/palletctl/palletctl", {"info", dir.file("good")});
  CHECK(ok.exit_code == 0);
  CHECK(ok.err.empty());

  const Run help = run("src/palletctl/palletctl", {"info", "--help"});
  CHECK(help.exit_code == 0);
  CHECK_THAT(help.out, Contains("stems"));
}

TEST_CASE(
    "palletctl simulate, roi and eval on cell scenes: a region per cell frame, the no-box statuses scored") {
  TempDir dir;
  const std::string out = dir.file("cells");
  const Run sim = run("src/palletctl/palletctl", {"simulate", "--out", out, "-n", "2", "--scene", "cell",
                                                  "empty", "--profile", "o3d303", "--cell", "--seed", "5"});
  REQUIRE(sim.exit_code == 0);
  std::vector<std::string> cells;
  for (const auto& e : fs::directory_iterator(out)) {
    const std::string name = e.path().filename().string();
    if (name.size() > 9 && name.substr(name.size() - 9) == ".roi.yaml") cells.push_back(e.path().string());
  }
  REQUIRE(cells.size() == 2);  // --cell: every frame stands in a cell and has its region

  const std::string stem = cells.front().substr(0, cells.front().size() - 9);
  const Run roi = run("src/palletctl/palletctl", {"roi", stem});
  CHECK(roi.exit_code == 0);
  CHECK_THAT(roi.out,
             Contains("detection:") && Contains("roi:") && Contains("frame: base") && Contains("min_m:"));
  // The frame's calibration comes with the region: the snippet alone is a configuration the daemon
  // accepts too (its base-frame region needs camera_to_base in the file).
  CHECK_THAT(roi.out, Contains("camera_to_base: ["));
  const std::string snippet = dir.file("snippet.yaml");
  write(snippet, roi.out);
  const Run with_snippet =
      run("src/palletctl/palletctl", {"detect", stem, "--box", "600x400", "--config", snippet});
  INFO(with_snippet.err);
  CHECK(with_snippet.exit_code == 0);
  CHECK_THAT(with_snippet.out, Contains("\"status\":"));

  const Run eval = run("src/palletctl/palletctl", {"eval", out, "--cell-files", "-q"});
  CHECK(eval.exit_code == 0);
  CHECK_THAT(eval.out, Contains("unflagged wrong 0") && Contains("empty pallets 1: empty 1"));

  // An empty pallet is an answer, not a failed frame: palletctl detect exits 0.
  std::string empty_stem;
  for (const std::string& c : cells)
    if (c.find("_empty_") != std::string::npos) empty_stem = c.substr(0, c.size() - 9);
  REQUIRE_FALSE(empty_stem.empty());
  // The cell's region and pallet height in a configuration, with the frame's own calibration.
  const std::string config = dir.file("cell.yaml");
  write(config, slurp(empty_stem + ".roi.yaml") + camera_to_base_of(empty_stem));
  const Run detect =
      run("src/palletctl/palletctl", {"detect", empty_stem, "--box", "400x300", "--config", config});
  CHECK(detect.exit_code == 0);
  CHECK_THAT(detect.out, Contains("\"status\":\"empty\""));
}

TEST_CASE("palletctl detect with a cell file as configuration takes camera_to_base from each frame") {
  TempDir dir;
  const std::string stem = simulate_cell_frame(dir, "empty", "7");
  // The file beside the frame holds a base-frame region and the pallet's height, no calibration.
  REQUIRE(slurp(stem + ".roi.yaml").find("camera_to_base") == std::string::npos);
  const Run detect =
      run("src/palletctl/palletctl", {"detect", stem, "--box", "400x300", "--config", stem + ".roi.yaml"});
  INFO(detect.err);
  CHECK(detect.exit_code == 0);
  CHECK_THAT(detect.out, Contains("\"status\":\"empty\""));

  // A copy of the frame whose JSON has no camera_to_base fails alone, named, and the frame beside
  // it in the same run still gets its answer.
  const std::string bare = dir.file("bare");
  fs::copy_file(stem + ".depth.png", bare + ".depth.png");
  std::string json = slurp(stem + ".json");
  const std::size_t key = json.find("\"camera_to_base\"");
  REQUIRE(key != std::string::npos);
  const std::size_t end = json.find(']', key);
  const std::size_t comma = json.rfind(',', key);  // camera_to_base is not the JSON's first key
  REQUIRE(comma != std::string::npos);
  json.erase(comma, end + 1 - comma);
  write(bare + ".json", json);
  REQUIRE_FALSE(palletd::read_frame(bare)->T_base_camera.has_value());
  const Run both = run("src/palletctl/palletctl",
                       {"detect", bare, stem, "--box", "400x300", "--config", stem + ".roi.yaml"});
  CHECK(both.exit_code != 0);
  CHECK_THAT(both.out, Contains("no camera_to_base") && Contains("\"status\":\"empty\""));
}

TEST_CASE("palletctl compare lists the frames whose result differs between two configurations") {
  TempDir dir;
  const std::string formats =
      "formats:\n  - {name: 600x400, long_mm: 600, short_mm: 400}\n"
      "  - {name: 400x300, long_mm: 400, short_mm: 300}\n";
  const std::string a = dir.file("a.yaml"), b = dir.file("b.yaml");
  write(a, formats + "recipes:\n  - {number: 1, name: r, formats: [600x400]}\n");
  write(b, formats + "recipes:\n  - {number: 1, name: r, formats: [400x300]}\n");
  const std::string frame = kSource + "/tests/data/01_block_600x400_o3d303";
  const std::string overlays = dir.file("overlays");

  const Run same =
      run("src/palletctl/palletctl", {"compare", "--config", a, "--config", a, "--recipe", "1", frame});
  CHECK(same.exit_code == 0);
  CHECK(same.out.empty());

  const Run differ = run("src/palletctl/palletctl", {"compare", "--config", a, "--config", b, "--recipe", "1",
                                                     "--overlay", overlays, "--json", frame});
  CHECK(differ.exit_code == 1);
  CHECK_THAT(differ.out, Contains("\"frame\":\"" + frame + "\"") && Contains("\"difference\""));
  CHECK(fs::file_size(overlays + "/01_block_600x400_o3d303.a.overlay.png") > 0);
  CHECK(fs::file_size(overlays + "/01_block_600x400_o3d303.b.overlay.png") > 0);

  const Run missing = run("src/palletctl/palletctl", {"compare", "--config", a, "--config", b, "--recipe",
                                                      "1", dir.file("no_such_frame")});
  CHECK(missing.exit_code == 2);
  CHECK_THAT(missing.err, Contains("no_such_frame"));
  const Run one = run("src/palletctl/palletctl", {"compare", "--config", a, "--recipe", "1", frame});
  CHECK(one.exit_code == 2);
  CHECK_THAT(one.err, Contains("--config twice"));
}

TEST_CASE("palletctl drift: --set writes a reference, frames are measured against it") {
  TempDir dir;
  const std::string stem = simulate_cell_frame(dir, "cell", "8");
  const std::string config = dir.file("cell.yaml");
  write(config, slurp(stem + ".roi.yaml") + camera_to_base_of(stem) +
                    "health:\n  drift_reference: " + dir.file("ref/drift") + "\n");

  const Run set = run("src/palletctl/palletctl", {"drift", "--config", config, "--set", "--frame", stem});
  INFO(set.err);
  REQUIRE(set.exit_code == 0);
  CHECK_THAT(set.out, Contains("fixed points"));
  CHECK(fs::exists(dir.file("ref/drift.depth.png")));

  const Run same = run("src/palletctl/palletctl", {"drift", "--config", config, stem});
  INFO(same.err);
  CHECK(same.exit_code == 0);
  CHECK_THAT(same.out, Contains("shift 0.0 mm") && Contains("turn 0.00 deg"));

  const Run missing = run("src/palletctl/palletctl", {"drift", "--config", config, dir.file("none")});
  CHECK(missing.exit_code == 2);
  CHECK_THAT(missing.out, Contains("none"));
  const Run nothing = run("src/palletctl/palletctl", {"drift", "--config", config});
  CHECK(nothing.exit_code == 2);

  // Without --frame the reference comes from the configured camera (here the replay driver).
  const std::string camera_config = dir.file("camera.yaml");
  write(camera_config,
        slurp(config) + "camera:\n  driver: replay\n  replay:\n    directory: " + dir.file("cells") + "\n");
  fs::remove(dir.file("ref/drift.depth.png"));
  const Run grabbed = run("src/palletctl/palletctl", {"drift", "--config", camera_config, "--set"});
  INFO(grabbed.err);
  CHECK(grabbed.exit_code == 0);
  CHECK(fs::exists(dir.file("ref/drift.depth.png")));
}

TEST_CASE("palletctl detect --config with a gripper: pickable, blocked_by, tcp and groups in the JSON") {
  TempDir dir;
  const std::string config = dir.file("gripper.yaml");
  write(config, "gripper:\n  footprint_mm: [600, 400]\n  clearance_mm: 5\n");
  const std::string frame = std::string(PALLETD_TEST_DATA_DIR) + "/01_block_600x400_o3d303";
  const Run detect = run("src/palletctl/palletctl", {"detect", frame, "--box", "600x400", "--config", config});
  REQUIRE(detect.exit_code == 0);
  const auto j = nlohmann::json::parse(detect.out);
  REQUIRE(j["status"] == "ok");
  REQUIRE(j.contains("groups"));
  int pickable = 0;
  for (const auto& box : j["boxes"]) {
    REQUIRE(box.contains("pickable"));
    REQUIRE(box["tcp"]["position"].size() == 3);
    pickable += box["pickable"].get<bool>() ? 1 : 0;
    if (!box["pickable"].get<bool>()) CHECK(box["blocked_by"] != "");
  }
  CHECK(pickable >= 1);
  CHECK(j["groups"].size() == static_cast<std::size_t>(pickable));  // one box per pick with this gripper
  // Without a gripper the keys are absent.
  const Run plain = run("src/palletctl/palletctl", {"detect", frame, "--box", "600x400"});
  const auto k = nlohmann::json::parse(plain.out);
  CHECK_FALSE(k.contains("groups"));
  CHECK_FALSE(k["boxes"][0].contains("pickable"));
}

TEST_CASE("palletctl teach prints config entries palletd accepts, and detect takes a size-range recipe") {
  TempDir dir;
  const std::string frame = kSource + "/tests/data/12_block_300x200_holes_o3d303";
  const std::string overlay = dir.file("taught.png");
  const Run taught = run("src/palletctl/palletctl", {"teach", frame, "--number", "7", "--overlay", overlay});
  INFO(taught.out << taught.err);
  CHECK(taught.exit_code == 0);
  CHECK_THAT(taught.out, Contains("12 carton(s) of 30") && Contains("recipes:") && Contains("number: 7"));
  CHECK(fs::file_size(overlay) > 0);
  const std::string config = dir.file("taught.yaml");
  write(config, taught.out + "pipeline:\n  default_recipe: 7\n");
  const Run check = run("src/palletd/palletd", {"--check-config", config});
  CHECK(check.exit_code == 0);

  const std::string range = dir.file("range.yaml");
  write(range, "recipes:\n  - {number: 90, size_range_mm: {long: [200, 800], short: [150, 600]}}\n"
               "pipeline:\n  default_recipe: 90\n");
  const Run detected = run("src/palletctl/palletctl", {"detect", "--config", range, "--recipe", "90", frame});
  CHECK(detected.exit_code == 0);
  CHECK_THAT(detected.out, Contains("\"format\":-1") && Contains("\"formats_measured\":true"));

  const Run missing = run("src/palletctl/palletctl", {"teach", dir.file("no_such_frame")});
  CHECK(missing.exit_code == 2);
  CHECK_THAT(missing.err, Contains("no_such_frame"));
}

TEST_CASE("palletctl detect --debug-dir draws the layer the detection found inside the region of interest") {
  TempDir dir;
  const std::string stem = simulate_cell_frame(dir, "cell", "11");
  const std::string name = fs::path(stem).filename().string();
  // Layer pixels are tinted green on the grey depth image (render_layer_debug_images).
  auto layer_pixels = [&](const std::string& debug_dir) {
    const cv::Mat img = cv::imread(debug_dir + "/" + name + ".layer_mask.png", cv::IMREAD_COLOR);
    REQUIRE_FALSE(img.empty());
    std::vector<cv::Point> pts;
    for (int v = 0; v < img.rows; ++v)
      for (int u = 0; u < img.cols; ++u) {
        const auto& px = img.at<cv::Vec3b>(v, u);
        if (px[1] >= 128 && px[1] > px[0] + 40 && px[1] > px[2] + 40) pts.emplace_back(u, v);
      }
    return pts;
  };
  const std::string with_roi = dir.file("with_roi"), without = dir.file("without");
  fs::create_directories(with_roi);
  fs::create_directories(without);
  const Run in_cell = run("src/palletctl/palletctl", {"detect", stem, "--box", "400x300", "--config",
                                                      stem + ".roi.yaml", "--debug-dir", with_roi});
  const Run whole_view =
      run("src/palletctl/palletctl", {"detect", stem, "--box", "400x300", "--debug-dir", without});
  INFO(in_cell.err << whole_view.err);
  const auto layer_area = [](const std::string& out) {
    return nlohmann::json::parse(out.substr(0, out.find('\n')))["layer"]["area_m2"].get<double>();
  };
  // The cabinet's top is the highest plane in the whole view; the load's top inside the region.
  REQUIRE(std::abs(layer_area(in_cell.out) - layer_area(whole_view.out)) > 0.02);
  const std::vector<cv::Point> a = layer_pixels(with_roi), b = layer_pixels(without);
  REQUIRE(a.size() > 100);
  REQUIRE(b.size() > 100);
  const cv::Rect box_a = cv::boundingRect(a), box_b = cv::boundingRect(b);
  CHECK((box_a & box_b).area() < box_a.area() / 2);  // two different planes, not one drawn twice
}
