// The palletd executable as systemd runs it: sd_notify on a test NOTIFY_SOCKET, a Modbus trigger,
// SIGHUP reload (a broken file keeps the old config), SIGTERM stop within a second; and the
// systemd unit checked by systemd-analyze.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

// The harness the reliability tests run palletd with (free ports, the notify socket, spawning).
#include "../reliability/daemon_harness.hpp"
#include "palletd/modbus/client.hpp"

using namespace palletd::test;

TEST_CASE("palletd notifies systemd, answers a trigger, survives a broken reload and stops on SIGTERM") {
  TempDir dir("daemon");
  const fs::path config = dir.path / "palletd.yaml";
  fs::copy_file(std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml", config, fs::copy_options::overwrite_existing);
  const int port = free_port();
  NotifySocket notify;
  Daemon daemon({"--config", config.string(), "--replay", PALLETD_TEST_DATA_DIR, "--port", std::to_string(port),
                 "--web-port", std::to_string(free_port())},
                notify.path, dir.path / "palletd.log");

  REQUIRE(wait_ready(notify, daemon, 10s));
  CHECK(notify.seen.find("STATUS=") != std::string::npos);

  palletd::modbus::PlcClient plc("127.0.0.1", port, 1);
  REQUIRE(plc.connect().ok());
  auto first = plc.trigger(1, 11, 10s);
  REQUIRE(first.ok());
  CHECK(first->result.record.request_id == 11);

  // A broken file on SIGHUP: the old configuration stays in force and the service keeps answering.
  { std::ofstream(config) << "modbus:\n  port: [not a number\n"; }
  REQUIRE(::kill(daemon.pid, SIGHUP) == 0);
  CHECK(notify.wait_for("reload refused", 5s));
  auto second = plc.trigger(1, 12, 10s);
  REQUIRE(second.ok());
  CHECK(second->result.record.request_id == 12);

  // A good file on SIGHUP: a recipe added there is known to the next trigger.
  {
    std::ifstream in(std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string anchor = "recipes:\n";
    const auto at = text.find(anchor);
    REQUIRE(at != std::string::npos);
    text.insert(at + anchor.size(), "  - {number: 42, name: added, formats: [600x400]}\n");
    std::ofstream(config) << text;
  }
  auto unknown = plc.trigger(42, 13, 10s);
  REQUIRE(unknown.ok());
  CHECK(unknown->status.error == palletd::modbus::ErrorCode::kUnknownRecipe);
  REQUIRE(::kill(daemon.pid, SIGHUP) == 0);
  CHECK(notify.wait_for("RELOADING=1", 5s));  // skips what the first reload left in the socket
  CHECK(notify.wait_for("READY=1", 5s));
  const std::uint16_t clear = palletd::modbus::kCtlClearError, zero = 0;
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &clear, 1).ok());
  REQUIRE(plc.write(palletd::modbus::kRegControlWord, &zero, 1).ok());
  auto known = plc.trigger(42, 14, 10s);
  REQUIRE(known.ok());
  CHECK(known->status.error != palletd::modbus::ErrorCode::kUnknownRecipe);
  CHECK(known->result.record.recipe == 42);

  const auto t0 = std::chrono::steady_clock::now();
  REQUIRE(::kill(daemon.pid, SIGTERM) == 0);
  const int code = daemon.wait_exit(3s);
  const auto stop_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  CHECK(code == 0);
  CHECK(stop_ms < 1000.0);
  CHECK(notify.wait_for("STOPPING=1", 1s));
}

TEST_CASE("palletd refuses to start on a taken port and says why") {
  TempDir dir("daemon-port");
  const int port = free_port();
  NotifySocket notify;
  const std::string web_port = std::to_string(free_port());
  Daemon first({"--config", std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml", "--replay", PALLETD_TEST_DATA_DIR,
                "--port", std::to_string(port), "--web-port", web_port},
               notify.path, dir.path / "first.log");
  REQUIRE(wait_ready(notify, first, 10s));
  // Same Modbus port, a free web port: the Modbus port alone must stop it.
  Daemon second({"--config", std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml", "--replay",
                 PALLETD_TEST_DATA_DIR, "--port", std::to_string(port), "--web-port", std::to_string(free_port())},
                notify.path, dir.path / "second.log");
  CHECK(second.wait_exit(5s) == 1);
  CHECK(second.log_text().find(std::to_string(port)) != std::string::npos);  // says which port
  ::kill(first.pid, SIGTERM);
  CHECK(first.wait_exit(3s) == 0);
}

TEST_CASE("the systemd unit passes systemd-analyze verify") {
  if (std::system("command -v systemd-analyze >/dev/null 2>&1") != 0) {
    WARN("skipped: systemd-analyze is not installed");
    return;
  }
  // The configured unit names the installed binary; point it at the built one for the check.
  const std::string unit = std::string(PALLETD_BINARY_DIR) + "/systemd/palletd.service";
  TempDir tmp("unit");
  const fs::path& dir = tmp.path;
  std::ifstream in(unit);
  REQUIRE(in.good());
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string installed = PALLETD_INSTALLED_BINARY;
  for (std::size_t at = text.find(installed); at != std::string::npos; at = text.find(installed, at)) {
    text.replace(at, installed.size(), std::string(PALLETD_BINARY_DIR) + "/src/palletd/palletd");
  }
  CHECK(text.find("Type=notify") != std::string::npos);
  { std::ofstream(dir / "palletd.service") << text; }
  const std::string cmd = "systemd-analyze verify " + (dir / "palletd.service").string() + " 2>&1";
  CHECK(std::system(cmd.c_str()) == 0);
  // And a broken unit is caught by the same check (the test can fail).
  { std::ofstream(dir / "broken.service") << "[Service]\nType=notify\nExecStart=relative/path\n"; }
  CHECK(std::system(("systemd-analyze verify " + (dir / "broken.service").string() + " >/dev/null 2>&1").c_str()) != 0);
}
