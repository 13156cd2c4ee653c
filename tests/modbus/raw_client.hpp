// Test helper: a plain TCP client that sends hand-made Modbus TCP frames (for what libmodbus as a
// client refuses to send: bad quantities, other protocol ids, wrong length fields, pipelining,
// half frames). Shared by the Modbus server tests and the reliability abuse test.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace palletd::modbus::test {

struct RawClientOptions {
  /// Local address to bind before connecting (e.g. "127.0.0.2" to come from another loopback
  /// address); "" = chosen by the kernel. Same family as the server address.
  std::string source;
  /// Connect without waiting for the handshake (a non-blocking socket, which it stays):
  /// connected() is true once the connection is under way. For opening many connections at once.
  bool nonblocking_connect = false;
};

class RawClient {
 public:
  RawClient(const std::string& address, std::uint16_t port, const RawClientOptions& options = {}) {
    sockaddr_storage server{};
    socklen_t len = 0;
    if (!to_sockaddr(address, port, server, len)) return;
    const int flags = SOCK_STREAM | SOCK_CLOEXEC | (options.nonblocking_connect ? SOCK_NONBLOCK : 0);
    fd_ = ::socket(server.ss_family, flags, 0);
    if (fd_ < 0) return;
    if (!options.source.empty()) {
      sockaddr_storage local{};
      socklen_t local_len = 0;
      if (!to_sockaddr(options.source, 0, local, local_len) || local.ss_family != server.ss_family ||
          ::bind(fd_, reinterpret_cast<sockaddr*>(&local), local_len) != 0) {
        return;
      }
    }
    const int rc = ::connect(fd_, reinterpret_cast<sockaddr*>(&server), len);
    connected_ = rc == 0 || (options.nonblocking_connect && errno == EINPROGRESS);
    const int on = 1;
    setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
  }
  ~RawClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;

  [[nodiscard]] bool connected() const { return connected_; }

  /// MBAP header + PDU. `length_override` >= 0 writes that length field instead of the true one
  /// (PDU size + 1) for malformed-header tests.
  static std::vector<std::uint8_t> frame(std::uint16_t tid, std::uint8_t unit,
                                         const std::vector<std::uint8_t>& pdu,
                                         std::uint16_t protocol = 0, int length_override = -1) {
    const auto length = static_cast<std::uint16_t>(length_override >= 0 ? length_override
                                                                         : static_cast<int>(pdu.size()) + 1);
    std::vector<std::uint8_t> f = {static_cast<std::uint8_t>(tid >> 8), static_cast<std::uint8_t>(tid),
                                   static_cast<std::uint8_t>(protocol >> 8), static_cast<std::uint8_t>(protocol),
                                   static_cast<std::uint8_t>(length >> 8), static_cast<std::uint8_t>(length),
                                   unit};
    f.insert(f.end(), pdu.begin(), pdu.end());
    return f;
  }
  /// A PDU of a function code and two 16-bit fields: address and quantity (reads, FC 1..4) or
  /// address and value (FC 5, 6).
  static std::vector<std::uint8_t> pdu(std::uint8_t function, std::uint16_t address, std::uint16_t value) {
    return {function, static_cast<std::uint8_t>(address >> 8), static_cast<std::uint8_t>(address),
            static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value)};
  }
  static std::vector<std::uint8_t> read_pdu(std::uint8_t function, std::uint16_t address, std::uint16_t count) {
    return pdu(function, address, count);
  }

  bool send(const std::vector<std::uint8_t>& bytes) {
    return ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size());
  }

  /// One response frame (header + PDU), or empty on timeout / closed connection.
  std::vector<std::uint8_t> receive(std::chrono::milliseconds timeout = std::chrono::milliseconds(1000)) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
      if (buffer_.size() >= 6) {
        const std::size_t size = 6 + ((static_cast<std::size_t>(buffer_[4]) << 8) | buffer_[5]);
        if (buffer_.size() >= size) {
          std::vector<std::uint8_t> out(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(size));
          buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(size));
          return out;
        }
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return {};
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return {};
      std::uint8_t chunk[4096];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) {
        closed_ = true;
        return {};
      }
      buffer_.insert(buffer_.end(), chunk, chunk + n);
    }
  }

  /// Waits (up to `timeout`) for the connection to become readable once and peeks: true when that
  /// is the peer's close. Pending answer bytes count as "not closed" and are left in the socket.
  bool closed_by_peer_peek(std::chrono::milliseconds timeout) {
    if (closed_) return true;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return false;
    std::uint8_t byte = 0;
    const ssize_t n = ::recv(fd_, &byte, 1, MSG_PEEK);
    closed_ = n <= 0;
    return closed_;
  }

  /// Reads and discards whatever arrives until the peer closes the connection or `timeout`
  /// passes: true when it closed (answers sent before the close do not matter).
  bool closed_by_peer_drain(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (!closed_ && std::chrono::steady_clock::now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      std::uint8_t chunk[256];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) closed_ = true;
    }
    return closed_;
  }

 private:
  static bool to_sockaddr(const std::string& address, std::uint16_t port, sockaddr_storage& ss, socklen_t& len) {
    if (address.find(':') != std::string::npos) {
      auto* in6 = reinterpret_cast<sockaddr_in6*>(&ss);
      in6->sin6_family = AF_INET6;
      in6->sin6_port = htons(port);
      len = sizeof(sockaddr_in6);
      return inet_pton(AF_INET6, address.c_str(), &in6->sin6_addr) == 1;
    }
    auto* in = reinterpret_cast<sockaddr_in*>(&ss);
    in->sin_family = AF_INET;
    in->sin_port = htons(port);
    len = sizeof(sockaddr_in);
    return inet_pton(AF_INET, address.c_str(), &in->sin_addr) == 1;
  }

  int fd_ = -1;
  bool connected_ = false;
  bool closed_ = false;
  std::vector<std::uint8_t> buffer_;
};

}  // namespace palletd::modbus::test
