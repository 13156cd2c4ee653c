// The Modbus TCP server's connections over loopback: the connection cap, allow and read-only
// lists, idle timeouts, IPv6, consistent reads while results are published, start and stop.
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "raw_client.hpp"
#include "server_fixture.hpp"

using namespace palletd::modbus;
using namespace palletd::modbus::test;
using std::chrono::milliseconds;

TEST_CASE("at the connection cap the longest idle connection is closed", "[modbus][server]") {
  ServerOptions o = loopback_options();
  o.max_connections = 2;
  auto log_lines = std::make_shared<std::vector<std::string>>();
  auto log_mutex = std::make_shared<std::mutex>();
  o.log = [log_lines, log_mutex](const std::string& line) {
    std::lock_guard<std::mutex> lock(*log_mutex);
    log_lines->push_back(line);
  };
  Server s(o);
  const auto ping = [](RawClient& c, std::uint16_t tid) {
    if (!c.send(RawClient::frame(tid, 1, RawClient::read_pdu(3, 108, 1)))) return false;
    const auto r = c.receive();
    return r.size() == 11 && tid_of(r) == tid;
  };
  RawClient c1("127.0.0.1", s.port());
  REQUIRE(ping(c1, 1));
  RawClient c2("127.0.0.1", s.port());
  REQUIRE(ping(c2, 2));
  std::this_thread::sleep_for(milliseconds(20));
  REQUIRE(ping(c1, 3));  // c2 is now the longest idle
  RawClient c3("127.0.0.1", s.port());
  REQUIRE(ping(c3, 4));
  CHECK(c2.closed_by_peer_peek(milliseconds(2000)));
  CHECK(ping(c1, 5));
  CHECK(ping(c3, 6));
  CHECK(s.server.stats().connections_evicted == 1);
  CHECK(s.server.stats().open_connections == 2);

  // More evictions from the same address (each new connection stays open, so the next one finds
  // the cap reached): counted in 140-141, logged once.
  std::vector<std::unique_ptr<RawClient>> extras;
  for (std::uint16_t i = 0; i < 5; ++i) {
    extras.push_back(std::make_unique<RawClient>("127.0.0.1", s.port()));
    REQUIRE(ping(*extras.back(), static_cast<std::uint16_t>(10 + i)));
  }
  const StatusRecord status = decode_status(s.server.registers(), HandshakeOptions{}.word_order);
  CHECK(status.connections.evicted == 6);
  CHECK(status.connections.refused == 0);
  CHECK(status.connections.max_connections == 2);
  CHECK(status.connections.open == 2);
  std::lock_guard<std::mutex> lock(*log_mutex);
  const auto cap_lines = std::count_if(log_lines->begin(), log_lines->end(), [](const std::string& l) {
    return l.find("connection cap") != std::string::npos;
  });
  CHECK(cap_lines == 1);
}

TEST_CASE("allow list refuses other peers, read-only peers cannot write", "[modbus][server]") {
  ServerOptions refused = loopback_options();
  refused.allow = {"10.0.0.0/8", "fd00::/8"};
  Server s1(refused);
  RawClient outsider("127.0.0.1", s1.port());
  CHECK(outsider.closed_by_peer_peek(milliseconds(2000)));
  // Statistics are published at the end of the loop iteration that closed the connection.
  const auto deadline = Clock::now() + std::chrono::seconds(2);
  while (s1.server.stats().connections_refused == 0 && Clock::now() < deadline) {
    std::this_thread::sleep_for(milliseconds(5));
  }
  CHECK(s1.server.stats().connections_refused == 1);

  ServerOptions ro = loopback_options();
  ro.allow = {"127.0.0.0/8"};
  ro.read_only = {"127.0.0.1/32"};
  Server s2(ro);
  Client reader("127.0.0.1", s2.port());
  REQUIRE(reader.connected);
  CHECK(reader.reg(kRegInterfaceVersion) == 1);
  CHECK(modbus_write_register(reader.ctx, 1, 5) == -1);
  CHECK(errno == EMBXILADD);
  CHECK(modbus_write_bit(reader.ctx, 0, 1) == -1);
  CHECK(errno == EMBXILADD);
  CHECK(reader.reg(1) == 0);
  CHECK(reader.reg(0) == 0);
  CHECK_FALSE(s2.server.wait_event(milliseconds(50)).has_value());

  ServerOptions bad = loopback_options();
  bad.allow = {"10.0.0.0/40"};
  ModbusServer refused_start(bad);
  CHECK_FALSE(refused_start.start().ok());
}

TEST_CASE("idle connections are closed after the idle timeout", "[modbus][server]") {
  ServerOptions o = loopback_options();
  o.idle_timeout_s = 0.3;
  Server s(o);
  RawClient quiet("127.0.0.1", s.port());
  Client busy("127.0.0.1", s.port());
  REQUIRE(quiet.connected());
  const auto start = Clock::now();
  bool closed = false;
  while (!closed && Clock::now() - start < std::chrono::seconds(3)) {
    REQUIRE(busy.reg(kRegInterfaceVersion) == 1);  // keeps `busy` active
    closed = quiet.closed_by_peer_peek(milliseconds(100));
  }
  CHECK(closed);
  CHECK(std::chrono::duration<double>(Clock::now() - start).count() >= 0.25);
  CHECK(busy.reg(kRegInterfaceVersion) == 1);
  CHECK(s.server.stats().connections_idle_closed == 1);
}

TEST_CASE("IPv6: bound to ::1, a libmodbus client reads over IPv6", "[modbus][server]") {
  ServerOptions o = loopback_options();
  o.bind_address = "::1";
  o.allow = {"::1/128"};
  Server s(o);
  Client c("::1", s.port());
  REQUIRE(c.connected);
  CHECK(c.reg(kRegInterfaceVersion) == 1);
  RawClient v4("127.0.0.1", s.port());
  CHECK_FALSE(v4.connected());  // bound to ::1 only
}

TEST_CASE("one read never mixes two results while results are published", "[modbus][server]") {
  Server s;
  Client c("127.0.0.1", s.port());
  REQUIRE(c.connected);
  std::atomic<bool> stop{false};
  std::thread publisher([&] {
    std::uint16_t k = 0;
    while (!stop) {
      ++k;
      auto r = std::make_shared<ResultRecord>();
      r->request_id = k;
      r->boxes_found = kMaxBoxes;
      for (int i = 0; i < kMaxBoxes; ++i) r->boxes.push_back(BoxRecord{0.001 * k, 0, 0, 0, 0, 1.0, k});
      s.server.publish_result(r);
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  });
  int checked = 0;
  int distinct = 0;
  std::uint16_t block[125] = {};
  std::uint16_t last_id = 0;
  bool ids_increase = true;
  // Read until many results went by (the publisher may be scheduled rarely on a busy machine).
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while ((distinct < 50 || checked < 300) && Clock::now() < deadline) {
    REQUIRE(modbus_read_registers(c.ctx, kResultStart, 125, block) == 125);
    if (block[0] == 0) continue;
    ++checked;
    if (block[0] < last_id) ids_increase = false;
    if (block[0] != last_id) ++distinct;
    last_id = block[0];
    const std::uint16_t request = block[1];
    for (int i = 0; i < 11; ++i) {  // boxes 0..10 lie in 210..319
      const std::uint16_t* slot = block + 10 + 10 * i;
      if (slot[9] != request || get_i32(slot, WordOrder::kHighWordFirst) != 10 * request) {
        FAIL("box " << i << " of result " << block[0] << " belongs to another result");
      }
    }
  }
  stop = true;
  publisher.join();
  CHECK(checked >= 300);
  CHECK(distinct >= 50);
  CHECK(ids_increase);
}

TEST_CASE("start fails on a taken port and twice, stop wakes waiters and is idempotent",
          "[modbus][server]") {
  Server first;
  ServerOptions same = loopback_options();
  same.port = first.port();
  ModbusServer second(same);
  const auto status = second.start();
  CHECK_FALSE(status.ok());
  CHECK(status.error().find(std::to_string(first.port())) != std::string::npos);
  CHECK_FALSE(first.server.start().ok());  // already started

  std::atomic<bool> woke{false};
  std::thread waiter([&] {
    (void)first.server.wait_event(milliseconds(10000));
    woke = true;
  });
  std::this_thread::sleep_for(milliseconds(50));
  const auto start = Clock::now();
  first.server.stop();
  waiter.join();
  CHECK(woke);
  CHECK(Clock::now() - start < std::chrono::seconds(1));
  first.server.stop();
  RawClient late("127.0.0.1", first.port());
  CHECK_FALSE(late.connected());  // the listening socket is closed
}
