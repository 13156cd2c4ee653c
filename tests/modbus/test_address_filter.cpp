#include <catch2/catch.hpp>

#include "palletd/modbus/address_filter.hpp"

using palletd::modbus::AddressFilter;

TEST_CASE("address lists match IPv4, IPv6, CIDR and IPv4-mapped peers", "[modbus][allow]") {
  auto filter = AddressFilter::parse({"192.168.10.0/24", "10.1.2.3", "fd00::/8", "::1", "172.16.0.0/12"});
  REQUIRE(filter.ok());
  CHECK(filter->matches(std::string("192.168.10.77")));
  CHECK_FALSE(filter->matches(std::string("192.168.11.1")));
  CHECK(filter->matches(std::string("10.1.2.3")));
  CHECK_FALSE(filter->matches(std::string("10.1.2.4")));
  CHECK(filter->matches(std::string("172.31.255.255")));
  CHECK_FALSE(filter->matches(std::string("172.32.0.0")));
  CHECK(filter->matches(std::string("fd12:3456::1")));
  CHECK_FALSE(filter->matches(std::string("fe80::1")));
  CHECK(filter->matches(std::string("::1")));
  CHECK_FALSE(filter->matches(std::string("::2")));
  CHECK(filter->matches(std::string("::ffff:192.168.10.5")));  // dual-stack socket view
  CHECK_FALSE(filter->matches(std::string("not an address")));
  CHECK(AddressFilter::parse({"0.0.0.0/0"})->matches(std::string("8.8.8.8")));
  CHECK(AddressFilter::parse({})->empty());
}

TEST_CASE("bad address list entries are refused with the entry named", "[modbus][allow]") {
  for (const char* bad : {"192.168.1.0/33", "::1/129", "10.0.0.1/", "10.0.0.1/x", "host.example", "1.2.3"}) {
    const auto filter = AddressFilter::parse({bad});
    INFO(bad);
    REQUIRE_FALSE(filter.ok());
    CHECK(filter.error().find(bad) != std::string::npos);
  }
}
