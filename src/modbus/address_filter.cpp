#include "palletd/modbus/address_filter.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstring>

namespace palletd::modbus {
namespace {

constexpr std::uint8_t kMappedPrefix[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF};

bool prefix_equal(const std::uint8_t* a, const std::uint8_t* b, int bits) {
  const int whole = bits / 8;
  if (std::memcmp(a, b, static_cast<std::size_t>(whole)) != 0) return false;
  const int rest = bits % 8;
  if (rest == 0) return true;
  const auto mask = static_cast<std::uint8_t>(0xFF << (8 - rest));
  return (a[whole] & mask) == (b[whole] & mask);
}

}  // namespace

Expected<AddressFilter> AddressFilter::parse(const std::vector<std::string>& entries) {
  AddressFilter filter;
  for (const std::string& text : entries) {
    const auto slash = text.find('/');
    const std::string host = text.substr(0, slash);
    Entry e;
    if (inet_pton(AF_INET, host.c_str(), e.bytes.data()) == 1) {
      e.v4 = true;
      e.prefix_bits = 32;
    } else if (inet_pton(AF_INET6, host.c_str(), e.bytes.data()) == 1) {
      e.prefix_bits = 128;
      if (std::memcmp(e.bytes.data(), kMappedPrefix, 12) == 0) {  // ::ffff:a.b.c.d -> IPv4
        std::memmove(e.bytes.data(), e.bytes.data() + 12, 4);
        e.v4 = true;
        e.prefix_bits = 32;
      }
    } else {
      return Error{"modbus address list: '" + text + "' is not an IPv4/IPv6 address or CIDR"};
    }
    if (slash != std::string::npos) {
      const std::string bits = text.substr(slash + 1);
      const int max_bits = e.v4 ? 32 : 128;
      int value = -1;
      if (!bits.empty() && bits.size() <= 3 &&
          bits.find_first_not_of("0123456789") == std::string::npos) {
        value = std::stoi(bits);
      }
      if (value < 0 || value > max_bits) {
        return Error{"modbus address list: '" + text + "' has a bad prefix length"};
      }
      e.prefix_bits = value;
    }
    filter.entries_.push_back(e);
  }
  return filter;
}

bool AddressFilter::matches_bytes(bool v4, const std::uint8_t* bytes) const {
  for (const Entry& e : entries_) {
    if (e.v4 == v4 && prefix_equal(e.bytes.data(), bytes, e.prefix_bits)) return true;
  }
  return false;
}

bool AddressFilter::matches(const sockaddr* address) const {
  if (address->sa_family == AF_INET) {
    sockaddr_in in{};
    std::memcpy(&in, address, sizeof in);
    std::uint8_t bytes[4];
    std::memcpy(bytes, &in.sin_addr, 4);
    return matches_bytes(true, bytes);
  }
  if (address->sa_family == AF_INET6) {
    sockaddr_in6 in6{};
    std::memcpy(&in6, address, sizeof in6);
    std::uint8_t bytes[16];
    std::memcpy(bytes, &in6.sin6_addr, 16);
    if (std::memcmp(bytes, kMappedPrefix, 12) == 0) return matches_bytes(true, bytes + 12);
    return matches_bytes(false, bytes);
  }
  return false;
}

bool AddressFilter::matches(const std::string& address) const {
  std::uint8_t bytes[16];
  if (inet_pton(AF_INET, address.c_str(), bytes) == 1) return matches_bytes(true, bytes);
  if (inet_pton(AF_INET6, address.c_str(), bytes) == 1) {
    if (std::memcmp(bytes, kMappedPrefix, 12) == 0) return matches_bytes(true, bytes + 12);
    return matches_bytes(false, bytes);
  }
  return false;
}

std::string address_to_string(const sockaddr* address) {
  char text[INET6_ADDRSTRLEN] = {};
  if (address->sa_family == AF_INET) {
    sockaddr_in in{};
    std::memcpy(&in, address, sizeof in);
    inet_ntop(AF_INET, &in.sin_addr, text, sizeof text);
  } else if (address->sa_family == AF_INET6) {
    sockaddr_in6 in6{};
    std::memcpy(&in6, address, sizeof in6);
    inet_ntop(AF_INET6, &in6.sin6_addr, text, sizeof text);
  }
  return text;
}

}  // namespace palletd::modbus
