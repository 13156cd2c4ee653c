// palletd modbus (private): the server's state, shared by server.cpp (start/stop and the
// thread-safe public interface) and server_loop.cpp (the poll loop thread).
#pragma once

#include <modbus.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cerrno>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "palletd/modbus/address_filter.hpp"
#include "palletd/modbus/server.hpp"

namespace palletd::modbus {
namespace detail {

using Clock = std::chrono::steady_clock;

class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  ~UniqueFd() { reset(); }
  UniqueFd(UniqueFd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept {
    if (this != &other) {
      reset();
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;
  [[nodiscard]] int get() const { return fd_; }
  [[nodiscard]] bool valid() const { return fd_ >= 0; }
  void reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

struct ModbusFree {
  void operator()(modbus_t* ctx) const { modbus_free(ctx); }
};
struct MappingFree {
  void operator()(modbus_mapping_t* m) const { modbus_mapping_free(m); }
};

struct Connection {
  UniqueFd fd;
  std::string peer;
  bool read_only = false;
  std::vector<std::uint8_t> buffer;  // bytes of the frame(s) not handled yet
  Clock::time_point last_activity;
  std::uint64_t requests = 0;  // complete frames received; 0 = never spoke Modbus
  bool closing = false;
};

inline std::string errno_text() { return std::strerror(errno); }

inline constexpr auto kMaxPollWait = std::chrono::milliseconds(200);
inline constexpr std::size_t kReadChunk = 4096;
inline constexpr std::size_t kMaxReadPerWakeup = 16 * kReadChunk;  // fairness between clients

}  // namespace detail

class ModbusServer::Impl {
  using Clock = detail::Clock;
  using UniqueFd = detail::UniqueFd;
  using Connection = detail::Connection;
 public:
  explicit Impl(ServerOptions options)
      : options_(std::move(options)),
        wake_fd_(eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

  Status start();
  void stop();
  void run();

  // shared with other threads
  ServerOptions options_;
  std::atomic<std::uint16_t> port_{0};
  std::atomic<bool> running_{false};
  bool started_ = false;  // owner thread only: a server starts once
  std::atomic<Clock::rep> last_alive_{0};
  std::thread thread_;
  UniqueFd wake_fd_;

  std::mutex published_mutex_;
  std::deque<std::shared_ptr<const ResultRecord>> pending_results_;
  std::shared_ptr<const ServiceStatus> pending_status_;
  std::atomic<bool> pending_{false};

  std::mutex events_mutex_;
  std::condition_variable events_cv_;
  std::deque<HandshakeEvent> events_;
  bool events_closed_ = false;

  mutable std::mutex image_mutex_;
  RegisterImage image_copy_{};
  ServerStats stats_copy_;

  // server thread only
  AddressFilter allow_;
  AddressFilter read_only_;
  UniqueFd listen_fd_;
  std::unique_ptr<modbus_t, detail::ModbusFree> ctx_;
  std::unique_ptr<modbus_mapping_t, detail::MappingFree> mapping_;
  std::optional<Handshake> handshake_;
  std::uint64_t synced_version_ = ~std::uint64_t{0};
  std::vector<std::unique_ptr<Connection>> connections_;
  ServerStats stats_;
  std::set<std::string> evicted_peers_;  // addresses evicted at least once (logged once each)

 private:
  void log(const std::string& message) const {
    if (options_.log) options_.log(message);
  }
  void wake() const {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t n = ::write(wake_fd_.get(), &one, sizeof one);
  }
  void absorb_published(Clock::time_point now);
  void sync_mapping();
  void push_events(const std::vector<HandshakeEvent>& events);
  void accept_all(Clock::time_point now);
  void serve(Connection& c, Clock::time_point now);
  void handle_frame(Connection& c, const std::uint8_t* frame, std::size_t size, Clock::time_point now);
  void publish_copies();
  void evict_one();
  void reply_exception(Connection& c, const std::uint8_t* frame, std::uint8_t code);
  void update_connection_registers();
  int poll_timeout_ms(Clock::time_point now) const;

  friend class ModbusServer;
};


}  // namespace palletd::modbus
