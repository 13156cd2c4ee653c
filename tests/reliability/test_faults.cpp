// Faults through the real palletd: corrupted and absurd frames replayed one per trigger (a status
// for each, never a crash), and the recording disk filling up or turning read-only (detection and
// Modbus go on, the error is reported, no half-written recording is left). The recording disk is a
// small tmpfs in a private mount namespace (unshare --user --mount), so no root is needed.
#include <cmath>
#include <map>
#include <random>

#include "daemon_harness.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"

using namespace palletd::test;
using namespace palletd::modbus;

namespace {

palletd::Frame blank_frame(int width, int height) {
  palletd::Frame f;
  f.intrinsics.width = width;
  f.intrinsics.height = height;
  f.intrinsics.fx = f.intrinsics.fy = 0.9 * width;
  f.intrinsics.cx = (width - 1) / 2.0;
  f.intrinsics.cy = (height - 1) / 2.0;
  f.depth_scale_m = 0.001;
  f.camera_id = "bad-frames";
  f.depth.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0);
  return f;
}

void write_or_fail(const fs::path& stem, const palletd::Frame& f) {
  const auto s = palletd::write_frame(stem.string(), f);
  INFO(stem << ": " << s.error());
  REQUIRE(s.ok());
}

/// Replaces `key`'s value in a frame's JSON text (numbers only, as the writer formats them).
void set_json_value(const fs::path& json, const std::string& key, const std::string& value) {
  std::string text = read_text(json);
  const auto at = text.find("\"" + key + "\"");
  REQUIRE(at != std::string::npos);
  const auto colon = text.find(':', at);
  const auto end = text.find_first_of(",}\n", colon);
  text.replace(colon + 1, end - colon - 1, " " + value);
  std::ofstream(json) << text;
}

/// The bad frames, in name order, and what each one is.
std::map<std::string, std::string> write_bad_frames(const fs::path& dir) {
  std::map<std::string, std::string> what;
  const int w = 176, h = 132;
  write_or_fail(dir / "a_all_invalid", blank_frame(w, h));
  what["a_all_invalid"] = "every pixel 0 (no measurement)";
  auto saturated = blank_frame(w, h);
  std::fill(saturated.depth.begin(), saturated.depth.end(), 65535);
  write_or_fail(dir / "b_saturated", saturated);
  what["b_saturated"] = "every pixel 65535 (65.5 m)";
  auto wall = blank_frame(w, h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)  // a wall seen almost edge-on: 0.4 m at the left, 6 m at the right
      wall.depth[static_cast<std::size_t>(v * w + u)] = static_cast<std::uint16_t>(400 + u * 32);
  write_or_fail(dir / "c_wall", wall);
  what["c_wall"] = "a wall instead of a pallet";
  auto noise = blank_frame(w, h);
  std::mt19937 rng(4711);
  for (auto& d : noise.depth) d = static_cast<std::uint16_t>(rng());
  write_or_fail(dir / "d_noise", noise);
  what["d_noise"] = "uniform random depth";
  auto checker = blank_frame(w, h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)  // every other pixel missing, the rest a flat floor
      checker.depth[static_cast<std::size_t>(v * w + u)] = static_cast<std::uint16_t>((u + v) % 2 ? 0 : 2000);
  write_or_fail(dir / "e_checkerboard", checker);
  what["e_checkerboard"] = "every other pixel invalid";
  write_or_fail(dir / "f_zero_intrinsics", saturated);
  for (const char* key : {"fx", "fy", "cx", "cy"}) set_json_value(dir / "f_zero_intrinsics.json", key, "0");
  what["f_zero_intrinsics"] = "fx = fy = cx = cy = 0";
  write_or_fail(dir / "g_huge_intrinsics", wall);
  set_json_value(dir / "g_huge_intrinsics.json", "fx", "1e308");
  set_json_value(dir / "g_huge_intrinsics.json", "depth_scale", "1e300");
  what["g_huge_intrinsics"] = "fx 1e308, depth_scale 1e300 (infinite coordinates)";
  write_or_fail(dir / "h_negative_scale", wall);
  set_json_value(dir / "h_negative_scale.json", "depth_scale", "-0.001");
  set_json_value(dir / "h_negative_scale.json", "fy", "-300");
  what["h_negative_scale"] = "negative depth_scale and fy";
  write_or_fail(dir / "i_one_pixel", blank_frame(1, 1));
  what["i_one_pixel"] = "a 1x1 image";
  write_or_fail(dir / "j_truncated_png", wall);
  {
    const std::string png = read_text(dir / "j_truncated_png.depth.png");
    std::ofstream(dir / "j_truncated_png.depth.png", std::ios::binary | std::ios::trunc) << png.substr(0, png.size() / 2);
  }
  what["j_truncated_png"] = "depth PNG cut in half";
  write_or_fail(dir / "k_garbage_json", wall);
  std::ofstream(dir / "k_garbage_json.json", std::ios::trunc) << "{\"width\": 176, \"height\": [";
  what["k_garbage_json"] = "metadata is not JSON";
  write_or_fail(dir / "l_size_mismatch", wall);
  set_json_value(dir / "l_size_mismatch.json", "width", "640");
  what["l_size_mismatch"] = "metadata says 640 wide, the PNG is 176";
  // The last one is a good frame: the daemon must still detect after all of the above.
  for (const char* ext : {".depth.png", ".json", ".intensity.png"}) {
    fs::copy_file(fs::path(PALLETD_TEST_DATA_DIR) / (std::string("01_block_600x400_o3d303") + ext),
                  dir / (std::string("z_good") + ext));
  }
  what["z_good"] = "a bundled good frame";
  return what;
}

std::string replay_config(const fs::path& frames, int port, const std::string& extra = "") {
  return "camera:\n  driver: replay\n  frame_timeout_ms: 1500\n  reconnect_min_s: 0.05\n  reconnect_max_s: 0.2\n"
         "  replay:\n    directory: " + frames.string() + "\n    loop: true\n"
         "modbus:\n  bind_address: 127.0.0.1\n  port: " + std::to_string(port) +
         "\npipeline:\n  default_recipe: 1\n  detection_timeout_ms: 5000\nlogging:\n  level: info\n" + extra;
}

}  // namespace

TEST_CASE("corrupted and absurd frames: a status per trigger and never a crash - the next good frame detects") {
  TempDir dir("badframes");
  const fs::path frames = dir.path / "frames";
  fs::create_directories(frames);
  const auto what = write_bad_frames(frames);
  const int port = free_port();
  const auto config = write_config(dir.path, replay_config(frames, port));
  NotifySocket notify;
  Daemon daemon({"--config", config.string()}, notify.path, dir.path / "palletd.log");
  REQUIRE(wait_ready(notify, daemon, 10s));

  PlcClient plc("127.0.0.1", port, 1);
  REQUIRE(plc.connect());
  std::uint16_t request = 1;
  // Twice round the folder (the replay driver loops): the same status for the same frame.
  std::map<std::string, std::pair<ResultStatus, ErrorCode>> first_round;
  for (int round = 0; round < 2; ++round) {
    for (const auto& [stem, description] : what) {
      auto r = plc.trigger(1, request, 15s);
      INFO(stem << " (" << description << "), round " << round << ": " << (r ? "" : r.error()));
      REQUIRE(r.ok());  // a result for every trigger
      CHECK(r->result.record.request_id == request);
      CHECK(r->result.result_id == request);
      const auto status = r->result.record.status;
      const auto error = r->status.error;
      // A failed result always carries an error code; a good one none.
      CHECK((status == ResultStatus::kFailed) == (error != ErrorCode::kNone));
      if (round == 0) {
        first_round[stem] = {status, error};
        std::printf("%-18s %-52s status %d error %d boxes %u\n", stem.c_str(), description.c_str(),
                    static_cast<int>(status), static_cast<int>(error), r->result.record.boxes_found);
      } else {
        CHECK(first_round[stem].first == status);
        CHECK(first_round[stem].second == error);
      }
      if (stem == "z_good") {
        CHECK(status == ResultStatus::kOk);
        CHECK(r->result.record.boxes_found > 0);
      } else if (stem == "a_all_invalid" || stem == "i_one_pixel" || stem == "j_truncated_png" ||
                 stem == "k_garbage_json" || stem == "l_size_mismatch" || stem == "f_zero_intrinsics") {
        CHECK(status == ResultStatus::kFailed);
      }
      if (status == ResultStatus::kFailed) {
        // ClearError, as a PLC does before the next trigger.
        const std::uint16_t clear = kCtlClearError, zero = 0;
        REQUIRE(plc.write(kRegControlWord, &clear, 1));
        REQUIRE(plc.write(kRegControlWord, &zero, 1));
      }
      ++request;
      REQUIRE(daemon.alive());
    }
  }
  ::kill(daemon.pid, SIGTERM);
  CHECK(daemon.wait_exit(3s) == 0);
}

namespace {

/// Files of the recording folder as the daemon sees it (inside its mount namespace).
struct RecordingView {
  fs::path dir;
  std::size_t partial_files() const {
    std::size_t n = 0;
    std::error_code ec;
    for (auto it = fs::directory_iterator(dir / ".partial", ec); !ec && it != fs::directory_iterator(); it.increment(ec)) ++n;
    return n;
  }
  /// Stems with a depth PNG that reads back whole; false when any file lacks its frame.
  bool all_whole(std::size_t& frames) const {
    frames = 0;
    bool ok = true;
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string name = e.path().filename().string();
      if (name[0] == '.') continue;
      const std::string stem = name.substr(0, name.find('.'));
      if (!fs::exists(dir / (stem + ".depth.png"))) {
        UNSCOPED_INFO("file without its frame: " << name);
        ok = false;
      }
      if (name == stem + ".depth.png") {
        auto f = palletd::read_frame((dir / stem).string());
        if (!f) {
          UNSCOPED_INFO("recording does not read back: " << f.error());
          ok = false;
        }
        ++frames;
      }
    }
    return ok;
  }
};

}  // namespace

TEST_CASE("recording disk full then read-only: detection and Modbus go on - the error is reported - no half-written file") {
  if (std::system("unshare -Urm true >/dev/null 2>&1") != 0) {
    WARN("skipped: no user + mount namespace here (unshare -Urm)");
    return;
  }
  TempDir dir("recdisk");
  const fs::path frames = dir.path / "frames";
  fs::create_directories(frames);
  for (const char* ext : {".depth.png", ".json", ".intensity.png"}) {
    fs::copy_file(fs::path(PALLETD_TEST_DATA_DIR) / (std::string("01_block_600x400_o3d303") + ext),
                  frames / (std::string("01_block") + ext));
  }
  const fs::path recordings = dir.path / "recordings";
  fs::create_directories(recordings);
  const int port = free_port();
  // A ring far larger than the disk: the disk fills before the ring prunes anything.
  const auto config = write_config(dir.path, replay_config(frames, port,
                                                           "recording:\n  enabled: true\n  directory: " +
                                                               recordings.string() +
                                                               "\n  max_bytes: 1000000000\n  every_trigger: true\n"
                                                               "  overlays: true\n"));
  NotifySocket notify;
  // unshare keeps the network (the test reaches the port) and gives palletd a 700 kB tmpfs.
  Daemon daemon({"--config", config.string()}, notify.path, dir.path / "palletd.log",
                {"unshare", "-Urm", "sh", "-c", "mount -t tmpfs -o size=700k tmpfs \"$0\" && exec \"$@\"",
                 recordings.string()});
  REQUIRE(wait_ready(notify, daemon, 10s));
  RecordingView view{fs::path("/proc/" + std::to_string(daemon.pid) + "/root") / recordings.relative_path()};

  PlcClient plc("127.0.0.1", port, 1);
  REQUIRE(plc.connect());
  std::uint16_t request = 1;
  std::uint16_t boxes = 0;
  const auto trigger_ok = [&] {
    auto r = plc.trigger(1, request, 15s);
    INFO("request " << request << ": " << (r ? "" : r.error()));
    REQUIRE(r.ok());
    CHECK(r->result.record.request_id == request);
    CHECK(r->result.record.status == ResultStatus::kOk);  // the recording never fails the result
    if (request == 1) boxes = r->result.record.boxes_found;
    CHECK(r->result.record.boxes_found == boxes);
    ++request;
  };
  const auto log_count = [&](const std::string& needle) {
    const std::string log = daemon.log_text();
    std::size_t n = 0;
    for (auto at = log.find(needle); at != std::string::npos; at = log.find(needle, at + 1)) ++n;
    return n;
  };
  // Until the disk is full (every recording of this frame is the same size), then two more.
  int after_full = 0;
  for (int i = 0; i < 20 && after_full < 2; ++i) {
    trigger_ok();
    for (int k = 0; k < 100 && log_count("recorded ") + log_count("recording: ") < static_cast<std::size_t>(request - 1); ++k)
      std::this_thread::sleep_for(20ms);
    if (log_count("recording: ") > 0) ++after_full;
  }
  REQUIRE(after_full == 2);
  std::size_t recorded = 0;
  CHECK(view.all_whole(recorded));
  CHECK(recorded == log_count("recorded "));
  CHECK(view.partial_files() == 0);
  CHECK(notify.wait_for("recording failed", 5s));  // STATUS= carries it

  // Read-only from now on (as a disk remounted read-only after an error).
  const std::string remount = "nsenter -t " + std::to_string(daemon.pid) +
                              " -U -m --preserve-credentials mount -o remount,ro " + recordings.string();
  REQUIRE(std::system(remount.c_str()) == 0);
  const std::size_t failures_before = log_count("recording: ");
  for (int i = 0; i < 3; ++i) trigger_ok();
  for (int k = 0; k < 100 && log_count("recording: ") < failures_before + 3; ++k) std::this_thread::sleep_for(20ms);
  CHECK(log_count("recording: ") == failures_before + 3);
  std::size_t still = 0;
  CHECK(view.all_whole(still));
  CHECK(still == recorded);
  CHECK(view.partial_files() == 0);
  CHECK(daemon.alive());
  ::kill(daemon.pid, SIGTERM);
  CHECK(daemon.wait_exit(3s) == 0);
}
