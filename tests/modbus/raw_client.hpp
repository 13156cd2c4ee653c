// Test helper: a plain TCP client that sends hand-made Modbus TCP frames (for what libmodbus as a
// client refuses to send: bad quantities, other protocol ids, pipelining, half frames).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace palletd::modbus::test {

class RawClient {
 public:
  RawClient(const std::string& address, std::uint16_t port) {
    sockaddr_storage ss{};
    socklen_t len = 0;
    if (address.find(':') != std::string::npos) {
      auto* in6 = reinterpret_cast<sockaddr_in6*>(&ss);
      in6->sin6_family = AF_INET6;
      in6->sin6_port = htons(port);
      inet_pton(AF_INET6, address.c_str(), &in6->sin6_addr);
      len = sizeof(sockaddr_in6);
    } else {
      auto* in = reinterpret_cast<sockaddr_in*>(&ss);
      in->sin_family = AF_INET;
      in->sin_port = htons(port);
      inet_pton(AF_INET, address.c_str(), &in->sin_addr);
      len = sizeof(sockaddr_in);
    }
    fd_ = ::socket(ss.ss_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
    connected_ = fd_ >= 0 && ::connect(fd_, reinterpret_cast<sockaddr*>(&ss), len) == 0;
    const int on = 1;
    if (fd_ >= 0) setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
  }
  ~RawClient() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawClient(const RawClient&) = delete;
  RawClient& operator=(const RawClient&) = delete;

  [[nodiscard]] bool connected() const { return connected_; }

  /// MBAP header + PDU.
  static std::vector<std::uint8_t> frame(std::uint16_t tid, std::uint8_t unit,
                                         const std::vector<std::uint8_t>& pdu,
                                         std::uint16_t protocol = 0) {
    const auto length = static_cast<std::uint16_t>(pdu.size() + 1);
    std::vector<std::uint8_t> f = {static_cast<std::uint8_t>(tid >> 8), static_cast<std::uint8_t>(tid),
                                   static_cast<std::uint8_t>(protocol >> 8), static_cast<std::uint8_t>(protocol),
                                   static_cast<std::uint8_t>(length >> 8), static_cast<std::uint8_t>(length),
                                   unit};
    f.insert(f.end(), pdu.begin(), pdu.end());
    return f;
  }
  static std::vector<std::uint8_t> read_pdu(std::uint8_t function, std::uint16_t address, std::uint16_t count) {
    return {function, static_cast<std::uint8_t>(address >> 8), static_cast<std::uint8_t>(address),
            static_cast<std::uint8_t>(count >> 8), static_cast<std::uint8_t>(count)};
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
      std::uint8_t chunk[1024];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) {
        closed_ = true;
        return {};
      }
      buffer_.insert(buffer_.end(), chunk, chunk + n);
    }
  }

  /// True once the server closed the connection (waits up to `timeout`).
  bool closed_by_peer(std::chrono::milliseconds timeout) {
    if (closed_) return true;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return false;
    std::uint8_t byte = 0;
    const ssize_t n = ::recv(fd_, &byte, 1, MSG_PEEK);
    closed_ = n <= 0;
    return closed_;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  bool closed_ = false;
  std::vector<std::uint8_t> buffer_;
};

}  // namespace palletd::modbus::test
