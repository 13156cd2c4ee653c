// Test harness for the tests that run the real palletd executable (tests/reliability, and
// tests/service/test_daemon.cpp): starts it as systemd would (NOTIFY_SOCKET, its output in a log
// file), stands in for systemd's notify socket, writes configurations, reads the daemon's RSS and
// open file descriptors from /proc, and hands out free loopback ports.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>
#include <fcntl.h>
#include <netinet/in.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace palletd::test {

/// How much longer the tests' deadlines are in this build (8 under the sanitizers, else 1).
inline constexpr int kTimeScale = PALLETD_TEST_TIME_SCALE;

/// `d` stretched for sanitizer builds.
inline std::chrono::milliseconds scaled(std::chrono::milliseconds d) { return d * kTimeScale; }

namespace fs = std::filesystem;
using namespace std::chrono_literals;

/// A loopback port free right now, never the same one twice in this process (the kernel may hand
/// a port that was just released out again, and a test asks for its Modbus and web ports in turn).
inline int free_port() {
  static std::mutex mutex;
  static std::set<int> handed_out;
  std::lock_guard<std::mutex> lock(mutex);
  for (;;) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
    socklen_t len = sizeof addr;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    ::close(fd);
    const int port = ntohs(addr.sin_port);
    if (handed_out.insert(port).second) return port;
  }
}

inline std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// A fresh folder, removed at the end of the scope.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) {
    static int counter = 0;
    path = fs::temp_directory_path() /
           ("palletd-rel-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

/// config/demo.yaml's formats and recipes with the given camera/modbus/... sections appended.
inline fs::path write_config(const fs::path& dir, const std::string& sections, const std::string& name = "palletd.yaml") {
  const std::string demo = read_text(std::string(PALLETD_SOURCE_DIR) + "/config/demo.yaml");
  const auto from = demo.find("formats:");
  const auto to = demo.find("modbus:");
  REQUIRE(from != std::string::npos);
  REQUIRE(to != std::string::npos);
  const fs::path path = dir / name;
  std::ofstream(path) << demo.substr(from, to - from) << sections;
  return path;
}

/// A unix datagram socket standing in for systemd's notify socket. Like systemd it reads every
/// message as it comes (a reader thread): a socket left unread fills its queue (10 datagrams)
/// and the daemon's next sd_notify blocks, which is not what a real service manager does.
/// wait_for takes the received messages in order.
struct NotifySocket {
  int fd = -1;
  std::string path;
  std::string seen;  ///< every message taken by wait_for so far, one per line
  NotifySocket() {
    static int counter = 0;
    path = (fs::temp_directory_path() /
            ("palletd-rel-notify-" + std::to_string(::getpid()) + "-" + std::to_string(counter++)))
               .string();
    ::unlink(path.c_str());
    fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
    REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
    timeval tv{0, 50000};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    reader_ = std::thread([this] {
      while (!stop_) {
        char buf[4096];
        const ssize_t n = ::recv(fd, buf, sizeof buf - 1, 0);
        if (n <= 0) continue;
        std::lock_guard<std::mutex> lock(mutex_);
        received_.emplace_back(buf, static_cast<std::size_t>(n));
        cv_.notify_all();
      }
    });
  }
  ~NotifySocket() {
    stop_ = true;
    reader_.join();
    ::close(fd);
    ::unlink(path.c_str());
  }
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;
  /// Takes messages in order until one not taken before contains `needle`, or the timeout passes.
  bool wait_for(const std::string& needle, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      while (!received_.empty()) {
        const std::string msg = std::move(received_.front());
        received_.pop_front();
        seen += msg + "\n";
        if (msg.find(needle) != std::string::npos) return true;
      }
      if (cv_.wait_until(lock, deadline) == std::cv_status::timeout && received_.empty()) return false;
    }
  }

 private:
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::string> received_;
  std::thread reader_;
};

/// The palletd executable of this build tree, run with `args`, output to `log` (empty: this
/// process's stdout and stderr). `prefix` runs it through another program (e.g. unshare); that
/// program must exec palletd so the pid stays.
struct Daemon {
  pid_t pid = -1;
  fs::path log;
  Daemon(const std::vector<std::string>& args, const std::string& notify_path, fs::path log_path,
         const std::vector<std::string>& prefix = {}, const std::vector<std::string>& extra_env = {})
      : log(std::move(log_path)) {
    std::vector<std::string> env_strings;
    for (char** e = environ; *e; ++e)
      if (std::string(*e).rfind("NOTIFY_SOCKET=", 0) != 0) env_strings.emplace_back(*e);
    if (!notify_path.empty()) env_strings.push_back("NOTIFY_SOCKET=" + notify_path);
    env_strings.insert(env_strings.end(), extra_env.begin(), extra_env.end());
    std::vector<char*> env;
    for (auto& s : env_strings) env.push_back(s.data());
    env.push_back(nullptr);
    std::vector<std::string> argv_strings = prefix;
    argv_strings.push_back(binary());
    argv_strings.insert(argv_strings.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& s : argv_strings) argv.push_back(s.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    if (!log.empty()) {
      posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      posix_spawn_file_actions_adddup2(&actions, 1, 2);
    }
    const int rc = prefix.empty() ? ::posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), env.data())
                                  : ::posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), env.data());
    posix_spawn_file_actions_destroy(&actions);
    REQUIRE(rc == 0);
  }
  ~Daemon() { kill_now(); }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  static std::string binary() { return std::string(PALLETD_BINARY_DIR) + "/src/palletd/palletd"; }

  void kill_now() {
    if (pid <= 0) return;
    ::kill(pid, SIGKILL);
    ::waitpid(pid, nullptr, 0);
    pid = -1;
  }
  /// True while the process has not exited (reaps it when it has).
  bool alive() {
    if (pid <= 0) return false;
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) {
      pid = -1;
      return false;
    }
    return true;
  }
  /// Waits for the exit; the exit status, 128 + signal, or -1 on timeout.
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
    report_hang();
    return -1;
  }
  /// For a daemon that did not exit in time: every thread's stack (gdb, when installed) and the
  /// log's tail on stderr, which ctest shows with the failure.
  void report_hang() const {
    std::fprintf(stderr, "palletd (pid %d) has not exited; its threads:\n", static_cast<int>(pid));
    std::fflush(stderr);
    const std::string gdb = "command -v gdb >/dev/null && timeout 60 gdb -p " + std::to_string(pid) +
                            " -batch -nx -ex 'thread apply all bt 16' 2>&1 | grep -E '^(Thread|#)' >&2";
    if (std::system(gdb.c_str()) != 0) std::fprintf(stderr, "(no stacks: gdb missing or attach refused)\n");
    const std::string text = log_text();
    std::fprintf(stderr, "palletd log (last 3000 bytes):\n%s\n",
                 text.substr(text.size() > 3000 ? text.size() - 3000 : 0).c_str());
  }
  [[nodiscard]] std::string log_text() const { return log.empty() ? std::string() : read_text(log); }
  /// "running", "exited with N" or "killed by signal N", without reaping the process (a later
  /// alive() or wait_exit() still sees the exit).
  [[nodiscard]] std::string state() const {
    if (pid <= 0) return "not running";
    siginfo_t info{};
    if (::waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) != 0) return "unknown";
    if (info.si_pid == 0) return "running";
    if (info.si_code == CLD_EXITED) return "exited with " + std::to_string(info.si_status);
    return "killed by signal " + std::to_string(info.si_status);
  }
  /// The state and the log's last `bytes`: what a failure far from the daemon's start shows.
  [[nodiscard]] std::string tail(std::size_t bytes = 3000) const {
    const std::string text = log_text();
    return "palletd " + state() + "; its log (last " + std::to_string(bytes) + " bytes):\n" +
           text.substr(text.size() > bytes ? text.size() - bytes : 0);
  }
  [[nodiscard]] std::size_t open_fds() const {
    std::size_t n = 0;
    std::error_code ec;
    for (auto it = fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec); !ec && it != fs::directory_iterator();
         it.increment(ec))
      ++n;
    return n;
  }
  [[nodiscard]] long rss_kb() const {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
    return -1;
  }
};

/// Waits for READY=1 from `daemon`; when it does not come, the daemon's log goes to stderr (ctest
/// shows it with the failure: a port taken, a config refused, a crash) and the answer is false.
inline bool wait_ready(NotifySocket& notify, Daemon& daemon, std::chrono::milliseconds timeout) {
  if (notify.wait_for("READY=1", timeout)) return true;
  const std::string text = daemon.log_text();
  std::fprintf(
      stderr,
      "palletd sent no READY=1 in %lld ms (%s); notify messages:\n%s\nits log (last 3000 bytes):\n%s\n",
      static_cast<long long>(timeout.count()), daemon.alive() ? "still running" : "exited",
      notify.seen.c_str(), text.substr(text.size() > 3000 ? text.size() - 3000 : 0).c_str());
  return false;
}

/// Raises this process's soft limit on open files to the hard limit; returns the new soft limit.
inline rlim_t raise_fd_limit() {
  rlimit rl{};
  ::getrlimit(RLIMIT_NOFILE, &rl);
  rl.rlim_cur = rl.rlim_max;
  ::setrlimit(RLIMIT_NOFILE, &rl);
  ::getrlimit(RLIMIT_NOFILE, &rl);
  return rl.rlim_cur;
}

}  // namespace palletd::test
