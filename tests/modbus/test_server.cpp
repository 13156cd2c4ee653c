// The Modbus TCP server against real clients over loopback: libmodbus as the client for the
// function codes, hand-made frames (raw_client.hpp) for what libmodbus will not send.
#include <catch2/catch.hpp>
#include <modbus.h>

#include <atomic>
#include <cerrno>
#include <thread>

#include "palletd/modbus/server.hpp"
#include "raw_client.hpp"

using namespace palletd::modbus;
using palletd::modbus::test::RawClient;
using std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;

namespace {

ServerOptions loopback_options() {
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
bool wait_bits(Client& c, int address, std::uint16_t mask, std::uint16_t want) {
  const auto deadline = Clock::now() + std::chrono::seconds(2);
  while (Clock::now() < deadline) {
    if ((c.reg(address) & mask) == want) return true;
    std::this_thread::sleep_for(milliseconds(5));
  }
  return false;
}

std::uint8_t exception_of(const std::vector<std::uint8_t>& response) {
  if (response.size() != 9 || (response[7] & 0x80) == 0) return 0;
  return response[8];
}

std::uint16_t tid_of(const std::vector<std::uint8_t>& r) {
  return static_cast<std::uint16_t>((r.at(0) << 8) | r.at(1));
}

}  // namespace

TEST_CASE("status and result blocks read as holding and input registers (FC3, FC4)", "[modbus][server]") {
  Server s;
  Client c("127.0.0.1", s.port());
  REQUIRE(c.connected);
  std::uint16_t holding[kStatusCount] = {}, input[kStatusCount] = {};
  REQUIRE(modbus_read_registers(c.ctx, kStatusStart, kStatusCount, holding) == kStatusCount);
  REQUIRE(modbus_read_input_registers(c.ctx, kStatusStart, kStatusCount, input) == kStatusCount);
  CHECK(holding[kRegInterfaceVersion - kStatusStart] == 1);
  CHECK(holding[kRegTestPattern - kStatusStart] == 0x1234);
  CHECK(holding[kRegTestPattern + 1 - kStatusStart] == 0x5678);
  CHECK(input[kRegInterfaceVersion - kStatusStart] == 1);
  CHECK(input[kRegTestPattern - kStatusStart] == 0x1234);
  std::uint16_t many[125] = {};
  CHECK(modbus_read_registers(c.ctx, 0, 125, many) == 125);
  CHECK(modbus_read_input_registers(c.ctx, 406, 125, many) == 125);  // up to 530
  CHECK(modbus_read_registers(c.ctx, 530, 2, many) == -1);
  CHECK(errno == EMBXILADD);
  CHECK(modbus_read_input_registers(c.ctx, 600, 1, many) == -1);
  CHECK(errno == EMBXILADD);
}

TEST_CASE("the handshake over FC16 and FC6 with a published result", "[modbus][server]") {
  Server s;
  Client c("127.0.0.1", s.port());
  REQUIRE(c.connected);
  REQUIRE(wait_bits(c, kRegStatusWord, kStReady, kStReady));
  const std::uint16_t request[3] = {kCtlTrigger, 2, 77};
  REQUIRE(modbus_write_registers(c.ctx, 0, 3, request) == 3);
  const auto event = s.server.wait_event(milliseconds(2000));
  REQUIRE(event.has_value());
  CHECK(event->kind == EventKind::kTrigger);
  CHECK(event->recipe == 2);
  CHECK(event->request_id == 77);
  CHECK((c.reg(kRegStatusWord) & (kStBusy | kStTriggerAck)) == (kStBusy | kStTriggerAck));
  REQUIRE(modbus_write_register(c.ctx, 0, 0) == 1);
  CHECK((c.reg(kRegStatusWord) & kStTriggerAck) == 0);

  auto result = std::make_shared<ResultRecord>();
  result->request_id = event->request_id;
  result->recipe = event->recipe;
  result->boxes_found = 1;
  result->boxes.push_back(BoxRecord{-0.25, 0.5, 1.25, 90.0, 1, 0.75, 1});
  s.server.publish_result(result);
  REQUIRE(wait_bits(c, kRegStatusWord, kStResultReady | kStBusy, kStResultReady));
  std::uint16_t block[20] = {};
  REQUIRE(modbus_read_registers(c.ctx, kResultStart, 20, block) == 20);
  CHECK(block[0] == 1);   // result id
  CHECK(block[1] == 77);  // request id echo
  CHECK(block[4] == 1);   // boxes reported
  CHECK(get_i32(block + 10, WordOrder::kHighWordFirst) == -2500);
  CHECK(get_i32(block + 14, WordOrder::kHighWordFirst) == 12500);
  CHECK(block[16] == 9000);
  CHECK(c.reg(kResultIdCopy) == 1);
  REQUIRE(modbus_write_register(c.ctx, 0, kCtlResultAck) == 1);
  CHECK((c.reg(kRegStatusWord) & kStResultReady) == 0);
  CHECK(s.server.registers()[kRegResultId] == 1);
}

TEST_CASE("coils mirror the control word, discrete inputs the status word (FC1, FC2, FC5, FC15)",
          "[modbus][server]") {
  Server s;
  Client c("127.0.0.1", s.port());
  REQUIRE(c.connected);
  REQUIRE(modbus_write_bit(c.ctx, 3, 1) == 1);  // SaveSnapshot
  CHECK(c.reg(0) == kCtlSaveSnapshot);
  const auto event = s.server.wait_event(milliseconds(2000));
  REQUIRE(event.has_value());
  CHECK(event->kind == EventKind::kSaveSnapshot);
  std::uint8_t bits[16] = {};
  REQUIRE(modbus_read_bits(c.ctx, 0, 16, bits) == 16);
  for (int i = 0; i < 16; ++i) CHECK(bits[i] == (i == 3 ? 1 : 0));
  const std::uint8_t write[4] = {0, 1, 0, 0};
  REQUIRE(modbus_write_bits(c.ctx, 0, 4, write) == 4);
  CHECK(c.reg(0) == kCtlResultAck);
  REQUIRE(wait_bits(c, kRegStatusWord, kStReady, kStReady));
  const std::uint16_t status = c.reg(kRegStatusWord);
  REQUIRE(modbus_read_input_bits(c.ctx, 0, 16, bits) == 16);
  for (int i = 0; i < 8; ++i) CHECK(bits[i] == ((status >> i) & 1));  // heartbeat bit 7 may flip
  CHECK(modbus_read_bits(c.ctx, 1, 16, bits) == -1);
  CHECK(errno == EMBXILADD);
  CHECK(modbus_write_bit(c.ctx, 16, 1) == -1);
  CHECK(errno == EMBXILADD);
}

TEST_CASE("FC23 writes the control block and reads in one request", "[modbus][server]") {
  Server s;
  Client c("127.0.0.1", s.port());
  REQUIRE(c.connected);
  const std::uint16_t write[2] = {5, 66};
  std::uint16_t read[10] = {};
  REQUIRE(modbus_write_and_read_registers(c.ctx, 1, 2, write, 100, 10, read) == 10);
  CHECK(read[kRegInterfaceVersion - kStatusStart] == 1);
  CHECK(c.reg(1) == 5);
  CHECK(c.reg(2) == 66);
  CHECK(modbus_write_and_read_registers(c.ctx, 100, 1, write, 100, 1, read) == -1);
  CHECK(errno == EMBXILADD);
}

TEST_CASE("quantity limits, address ranges and unknown functions get their exceptions",
          "[modbus][server]") {
  Server s;
  RawClient raw("127.0.0.1", s.port());
  REQUIRE(raw.connected());
  auto ask = [&](const std::vector<std::uint8_t>& pdu) {
    REQUIRE(raw.send(RawClient::frame(1, 1, pdu)));
    return raw.receive();
  };
  const auto ok125 = ask(RawClient::read_pdu(3, 0, 125));
  REQUIRE(ok125.size() == 9 + 250);
  CHECK(ok125[8] == 250);
  CHECK(exception_of(ask(RawClient::read_pdu(3, 0, 126))) == 3);
  CHECK(exception_of(ask(RawClient::read_pdu(4, 0, 126))) == 3);
  CHECK(exception_of(ask(RawClient::read_pdu(3, 0, 0))) == 3);
  CHECK(exception_of(ask(RawClient::read_pdu(3, 500, 31))) == 0);
  CHECK(exception_of(ask(RawClient::read_pdu(3, 500, 32))) == 2);
  CHECK(exception_of(ask(RawClient::read_pdu(4, 531, 1))) == 2);
  CHECK(exception_of(ask(RawClient::read_pdu(1, 0, 2001))) == 3);
  CHECK(exception_of(ask({5, 0, 0, 0x12, 0x34})) == 3);  // coil value neither 0 nor FF00
  CHECK(exception_of(ask({0x07})) == 1);
  CHECK(exception_of(ask({0x11})) == 1);
  CHECK(exception_of(ask({0x2B, 0x0E, 0x01, 0x00})) == 1);
  CHECK(exception_of(ask({3, 0, 0})) == 3);  // truncated PDU

  // Writes outside the control block change nothing.
  std::vector<std::uint8_t> fc16 = {16, 0, 10, 0, 7, 14};
  for (int i = 0; i < 7; ++i) fc16.insert(fc16.end(), {0, 9});
  CHECK(exception_of(ask(fc16)) == 2);
  CHECK(exception_of(ask({6, 0, 100, 0, 1})) == 2);
  // 124 registers cannot even be framed (PDU > 253 bytes): quantity checked first -> 03.
  CHECK(exception_of(ask({16, 0, 0, 0, 124, 248, 0, 1})) == 3);
  std::vector<std::uint8_t> fc16_123 = {16, 0, 0, 0, 123, 246};
  fc16_123.resize(6 + 246, 0);
  CHECK(exception_of(ask(fc16_123)) == 2);  // a legal quantity, but beyond the control block
  const auto regs = s.server.registers();
  for (int a = 10; a < 16; ++a) CHECK(regs[static_cast<std::size_t>(a)] == 0);
  CHECK(regs[kRegStatusWord] != 1);
  CHECK(regs[kRegInterfaceVersion] == 1);
}

TEST_CASE("illegal requests are answered at once and never stall another client", "[modbus][server]") {
  Server s;
  RawClient bad("127.0.0.1", s.port());
  Client good("127.0.0.1", s.port());
  REQUIRE(bad.connected());
  REQUIRE(good.connected);
  std::vector<std::uint8_t> burst;
  for (std::uint16_t i = 0; i < 10; ++i) {
    const auto f = RawClient::frame(i, 1, i % 2 == 0 ? RawClient::read_pdu(3, 0, 126)
                                                     : std::vector<std::uint8_t>{0x41});
    burst.insert(burst.end(), f.begin(), f.end());
  }
  const auto start = Clock::now();
  REQUIRE(bad.send(burst));
  std::uint16_t v = 0;
  REQUIRE(modbus_read_registers(good.ctx, kRegInterfaceVersion, 1, &v) == 1);
  const auto good_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  for (std::uint16_t i = 0; i < 10; ++i) {
    const auto r = bad.receive();
    REQUIRE(tid_of(r) == i);
    CHECK(exception_of(r) == (i % 2 == 0 ? 3 : 1));
  }
  const auto bad_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  // libmodbus' own error path would sleep 500 ms per request (5 s here).
  CHECK(good_ms < 400.0);
  CHECK(bad_ms < 400.0);
}

TEST_CASE("pipelined requests: transaction and unit ids echoed, protocol id != 0 dropped",
          "[modbus][server]") {
  Server s;
  RawClient raw("127.0.0.1", s.port());
  REQUIRE(raw.connected());
  std::vector<std::uint8_t> burst;
  const auto append = [&](const std::vector<std::uint8_t>& f) { burst.insert(burst.end(), f.begin(), f.end()); };
  append(RawClient::frame(0x0105, 1, RawClient::read_pdu(3, 108, 1), /*protocol=*/1));
  for (std::uint16_t tid = 0x0200; tid < 0x0208; ++tid) append(RawClient::frame(tid, 1, RawClient::read_pdu(3, 108, 1)));
  append(RawClient::frame(0x0300, 9, RawClient::read_pdu(3, 108, 1)));  // other unit id
  REQUIRE(raw.send(burst));
  for (std::uint16_t tid = 0x0200; tid < 0x0208; ++tid) {
    const auto r = raw.receive();
    REQUIRE(r.size() == 11);
    CHECK(tid_of(r) == tid);
    CHECK(r[6] == 1);
    CHECK(r[10] == 1);  // register 108
  }
  const auto other = raw.receive();
  CHECK(tid_of(other) == 0x0300);
  CHECK(other[6] == 9);
  CHECK(exception_of(other) == 0x0B);
  CHECK(raw.receive(milliseconds(200)).empty());  // nothing for the protocol-1 frame
  CHECK(s.server.stats().frames_dropped == 1);

  ServerOptions any = loopback_options();
  any.unit_id = 0;
  Server s_any(any);
  RawClient raw_any("127.0.0.1", s_any.port());
  REQUIRE(raw_any.send(RawClient::frame(42, 17, RawClient::read_pdu(4, 108, 1))));
  const auto r = raw_any.receive();
  REQUIRE(r.size() == 11);
  CHECK(r[6] == 17);
  CHECK(tid_of(r) == 42);
}

TEST_CASE("an impossible length field closes the connection", "[modbus][server]") {
  Server s;
  for (const std::uint8_t length_low : {std::uint8_t{0}, std::uint8_t{1}}) {
    RawClient raw("127.0.0.1", s.port());
    REQUIRE(raw.send({0, 1, 0, 0, 0, length_low, 1, 3}));
    CHECK(raw.closed_by_peer_peek(milliseconds(2000)));
  }
  RawClient big("127.0.0.1", s.port());
  REQUIRE(big.send({0, 1, 0, 0, 0x01, 0x00, 1, 3}));  // 256 > 254
  CHECK(big.closed_by_peer_peek(milliseconds(2000)));
}

TEST_CASE("a client trickling half a frame does not block others", "[modbus][server]") {
  Server s;
  RawClient slow("127.0.0.1", s.port());
  Client fast("127.0.0.1", s.port());
  REQUIRE(slow.connected());
  REQUIRE(fast.connected);
  const auto frame = RawClient::frame(7, 1, RawClient::read_pdu(3, 108, 1));
  for (std::size_t i = 0; i < frame.size(); ++i) {
    REQUIRE(slow.send({frame[i]}));
    const auto start = Clock::now();
    std::uint16_t v = 0;
    REQUIRE(modbus_read_registers(fast.ctx, kRegInterfaceVersion, 1, &v) == 1);
    CHECK(std::chrono::duration<double, std::milli>(Clock::now() - start).count() < 300.0);
    CHECK(v == 1);
    std::this_thread::sleep_for(milliseconds(20));
  }
  const auto r = slow.receive();
  REQUIRE(r.size() == 11);
  CHECK(tid_of(r) == 7);
}

TEST_CASE("at the connection cap the longest idle connection is closed", "[modbus][server]") {
  ServerOptions o = loopback_options();
  o.max_connections = 2;
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
