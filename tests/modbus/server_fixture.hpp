// The Modbus server tests' fixtures: a server on a free loopback port, a libmodbus client.
#pragma once

#include <catch2/catch.hpp>
#include <modbus.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "palletd/modbus/server.hpp"

namespace palletd::modbus::test {

using Clock = std::chrono::steady_clock;

inline ServerOptions loopback_options() {
  ServerOptions o;
  o.bind_address = "127.0.0.1";
  o.port = 0;  // a free port
  o.unit_id = 1;
  o.idle_timeout_s = 0.0;
  return o;
}

struct Server {
  ModbusServer server;
  explicit Server(ServerOptions o = loopback_options()) : server(std::move(o)) {
    const auto status = server.start();
    INFO(status.error());
    REQUIRE(status.ok());
    auto s = std::make_shared<ServiceStatus>();
    s->ready = true;
    s->camera_ok = true;
    server.publish_status(s);
  }
  [[nodiscard]] std::uint16_t port() const { return server.port(); }
};

struct Client {
  modbus_t* ctx = nullptr;
  bool connected = false;
  Client(const char* address, std::uint16_t port, int unit = 1) {
    ctx = modbus_new_tcp_pi(address, std::to_string(port).c_str());
    REQUIRE(ctx != nullptr);
    modbus_set_slave(ctx, unit);
    modbus_set_response_timeout(ctx, 2, 0);
    connected = modbus_connect(ctx) == 0;
  }
  ~Client() {
    modbus_close(ctx);
    modbus_free(ctx);
  }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;
  std::uint16_t reg(int address) {
    std::uint16_t v = 0;
    REQUIRE(modbus_read_registers(ctx, address, 1, &v) == 1);
    return v;
  }
};

// Polls register `address` until (value & mask) == want or 2 s pass.
inline bool wait_bits(Client& c, int address, std::uint16_t mask, std::uint16_t want) {
  const auto deadline = Clock::now() + std::chrono::seconds(2);
  while (Clock::now() < deadline) {
    if ((c.reg(address) & mask) == want) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

inline std::uint8_t exception_of(const std::vector<std::uint8_t>& response) {
  if (response.size() != 9 || (response[7] & 0x80) == 0) return 0;
  return response[8];
}

inline std::uint16_t tid_of(const std::vector<std::uint8_t>& r) {
  return static_cast<std::uint16_t>((r.at(0) << 8) | r.at(1));
}

}  // namespace palletd::modbus::test
