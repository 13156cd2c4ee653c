// Helpers of the service tests: bundled frames copied for the replay camera, the demo config
// pointed at them.
#pragma once

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include <catch2/catch.hpp>
#include <unistd.h>

#include "palletd/config/config.hpp"
#include "palletd/frames/frame_io.hpp"

namespace palletd::service_test {

namespace fs = std::filesystem;

// A temporary folder holding copies of bundled frames (named from tests/data, subfolders too).
struct TempFrames {
  fs::path dir;
  explicit TempFrames(const std::vector<std::string>& names) {
    dir = fs::temp_directory_path() /
          ("palletd-service-" + std::to_string(::getpid()) + "-" +
           std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
    fs::create_directories(dir);
    for (const auto& name : names) {
      for (const char* ext : {".depth.png", ".json", ".intensity.png"}) {
        const fs::path src = fs::path(PALLETD_TEST_DATA_DIR) / (name + ext);
        if (fs::exists(src)) fs::copy_file(src, dir / fs::path(name + ext).filename());
      }
    }
  }
  ~TempFrames() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

inline std::vector<std::string> bundled_stems(std::size_t n) {
  auto stems = palletd::list_frame_stems(PALLETD_TEST_DATA_DIR);
  REQUIRE(stems.ok());
  std::vector<std::string> names;
  for (const auto& s : *stems) {
    if (names.size() == n) break;
    names.push_back(fs::path(s).filename().string());
  }
  REQUIRE(names.size() == n);
  return names;
}

inline palletd::Config demo_config(const fs::path& replay_dir) {
  palletd::Config config = palletd::load_config(std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml");
  config.camera.driver = "replay";
  config.camera.replay.directory = replay_dir.string();
  config.camera.replay.rate_hz = 0.0;
  config.camera.frame_timeout_ms = 1500;
  config.modbus.bind_address = "127.0.0.1";
  config.modbus.port = 0;  // any free port
  config.recording.enabled = false;
  return config;
}

}  // namespace palletd::service_test
