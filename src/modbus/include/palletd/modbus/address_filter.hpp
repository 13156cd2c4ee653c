// palletd modbus: client address lists ("192.168.10.0/24", "10.0.0.5", "::1", "fd00::/8").
// IPv4-mapped IPv6 peers (::ffff:a.b.c.d, as seen on a dual-stack "::" socket) match IPv4
// entries. Immutable after parse(); safe to share between threads.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "palletd/core/expected.hpp"

struct sockaddr;

namespace palletd::modbus {

class AddressFilter {
 public:
  /// An empty list matches nothing (callers decide what "no list" means).
  static Expected<AddressFilter> parse(const std::vector<std::string>& entries);

  [[nodiscard]] bool empty() const { return entries_.empty(); }
  /// A socket address (AF_INET or AF_INET6).
  [[nodiscard]] bool matches(const sockaddr* address) const;
  /// A numeric address string.
  [[nodiscard]] bool matches(const std::string& address) const;

 private:
  struct Entry {
    bool v4 = false;
    std::array<std::uint8_t, 16> bytes{};
    int prefix_bits = 0;
  };
  [[nodiscard]] bool matches_bytes(bool v4, const std::uint8_t* bytes) const;
  std::vector<Entry> entries_;
};

/// "a.b.c.d" or "x:y::z" (without port) for a socket address.
std::string address_to_string(const sockaddr* address);

}  // namespace palletd::modbus
