// The palletd executable as systemd runs it: sd_notify on a test NOTIFY_SOCKET, a Modbus trigger,
// SIGHUP reload (a broken file keeps the old config), SIGTERM stop within a second; and the
// systemd unit checked by systemd-analyze.
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <netinet/in.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>

#include "palletd/modbus/client.hpp"

extern char** environ;
namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace {

int free_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

// A unix datagram socket standing in for systemd's notify socket.
struct NotifySocket {
  int fd = -1;
  std::string path;
  NotifySocket() {
    path = (fs::temp_directory_path() / ("palletd-notify-" + std::to_string(::getpid()))).string();
    ::unlink(path.c_str());
    fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
    REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
    timeval tv{0, 100000};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  ~NotifySocket() {
    ::close(fd);
    ::unlink(path.c_str());
  }
  // Collects messages until one contains `needle` or the timeout passes.
  bool wait_for(const std::string& needle, std::chrono::milliseconds timeout, std::string* all = nullptr) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      char buf[4096];
      const ssize_t n = ::recv(fd, buf, sizeof buf - 1, 0);
      if (n <= 0) continue;
      const std::string msg(buf, static_cast<std::size_t>(n));
      if (all) *all += msg + "\n";
      if (msg.find(needle) != std::string::npos) return true;
    }
    return false;
  }
};

struct Daemon {
  pid_t pid = -1;
  Daemon(const std::vector<std::string>& args, const std::string& notify_path) {
    std::vector<std::string> env_strings;
    for (char** e = environ; *e; ++e)
      if (std::string(*e).rfind("NOTIFY_SOCKET=", 0) != 0) env_strings.emplace_back(*e);
    env_strings.push_back("NOTIFY_SOCKET=" + notify_path);
    std::vector<char*> env;
    for (auto& s : env_strings) env.push_back(s.data());
    env.push_back(nullptr);
    std::vector<std::string> argv_strings{std::string(PALLETD_BINARY_DIR) + "/src/palletd/palletd"};
    argv_strings.insert(argv_strings.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& s : argv_strings) argv.push_back(s.data());
    argv.push_back(nullptr);
    REQUIRE(::posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), env.data()) == 0);
  }
  // Waits for the exit; returns the exit status or -1 on timeout.
  int wait_exit(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (::waitpid(pid, &status, WNOHANG) == pid) {
        pid = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(5ms);
    }
    return -1;
  }
  ~Daemon() {
    if (pid > 0) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
    }
  }
};

}  // namespace

TEST_CASE("palletd notifies systemd, answers a trigger, survives a broken reload and stops on SIGTERM") {
  const fs::path dir = fs::temp_directory_path() / ("palletd-daemon-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path config = dir / "palletd.yaml";
  fs::copy_file(std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml", config, fs::copy_options::overwrite_existing);
  const int port = free_port();
  NotifySocket notify;
  Daemon daemon({"--config", config.string(), "--replay", PALLETD_TEST_DATA_DIR, "--port", std::to_string(port),
                 "--web-port", std::to_string(free_port())},
                notify.path);

  std::string messages;
  REQUIRE(notify.wait_for("READY=1", 10s, &messages));
  CHECK(messages.find("STATUS=") != std::string::npos);

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
  fs::remove_all(dir);
}

TEST_CASE("palletd refuses to start on a taken port and says why") {
  const fs::path dir = fs::temp_directory_path() / ("palletd-daemon-port-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const int port = free_port();
  NotifySocket notify;
  const std::string web_port = std::to_string(free_port());
  Daemon first({"--config", std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml", "--replay", PALLETD_TEST_DATA_DIR,
                "--port", std::to_string(port), "--web-port", web_port},
               notify.path);
  REQUIRE(notify.wait_for("READY=1", 10s));
  // Same Modbus port, a free web port: the Modbus port alone must stop it.
  Daemon second({"--config", std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml", "--replay",
                 PALLETD_TEST_DATA_DIR, "--port", std::to_string(port), "--web-port", std::to_string(free_port())},
                notify.path);
  CHECK(second.wait_exit(5s) == 1);
  ::kill(first.pid, SIGTERM);
  CHECK(first.wait_exit(3s) == 0);
  fs::remove_all(dir);
}

TEST_CASE("the systemd unit passes systemd-analyze verify") {
  if (std::system("command -v systemd-analyze >/dev/null 2>&1") != 0) {
    WARN("skipped: systemd-analyze is not installed");
    return;
  }
  // The configured unit names the installed binary; point it at the built one for the check.
  const std::string unit = std::string(PALLETD_BINARY_DIR) + "/systemd/palletd.service";
  const fs::path dir = fs::temp_directory_path() / ("palletd-unit-" + std::to_string(::getpid()));
  fs::create_directories(dir);
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
  fs::remove_all(dir);
}
