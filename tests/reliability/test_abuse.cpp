// Abuse of the real palletd over loopback while the PLC keeps triggering: a burst of 1000
// connections, slow-byte senders, pipelined requests, malformed MBAP headers, oversize lengths,
// writes from a read-only and from an unlisted address. The connection cap and the allow-list
// hold and the PLC's own connection keeps working throughout.
#include <atomic>
#include <memory>
#include <random>

#include "daemon_harness.hpp"
#include "../modbus/raw_client.hpp"
#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"

using namespace palletd::test;
using namespace palletd::modbus;

namespace {

using palletd::modbus::test::RawClient;
using palletd::modbus::test::RawClientOptions;

/// How long an answer may take.
const std::chrono::milliseconds kAnswer = scaled(2000ms);

/// A client of the daemon at `port` coming from `source` (a loopback address).
std::unique_ptr<RawClient> raw(int port, const char* source = "127.0.0.1", bool nonblocking_connect = false) {
  RawClientOptions options;
  options.source = source;
  options.nonblocking_connect = nonblocking_connect;
  return std::make_unique<RawClient>("127.0.0.1", static_cast<std::uint16_t>(port), options);
}

/// A request frame with unit id 1.
std::vector<std::uint8_t> frame(std::uint16_t tid, const std::vector<std::uint8_t>& pdu, std::uint16_t protocol = 0,
                                int length_override = -1) {
  return RawClient::frame(tid, 1, pdu, protocol, length_override);
}
std::vector<std::uint8_t> pdu(std::uint8_t function, std::uint16_t address, std::uint16_t value) {
  return RawClient::pdu(function, address, value);
}

std::uint8_t exception_of(const std::vector<std::uint8_t>& r) {
  return r.size() == 9 && (r[7] & 0x80) != 0 ? r[8] : 0;
}
std::uint16_t tid_of(const std::vector<std::uint8_t>& r) { return static_cast<std::uint16_t>((r.at(0) << 8) | r.at(1)); }

/// The PLC: full handshakes every 200 ms on one connection until stopped.
struct PlcLoop {
  std::atomic<bool> stop{false};
  std::atomic<int> ok{0}, failed{0};
  std::string first_error;
  std::thread thread;
  explicit PlcLoop(int port) {
    thread = std::thread([this, port] {
      PlcClient plc("127.0.0.1", port, 1);
      if (!plc.connect()) {
        ++failed;
        return;
      }
      std::uint16_t id = 100;
      while (!stop) {
        auto r = plc.trigger(6, id++, scaled(10s));
        if (r) {
          ++ok;
        } else {
          if (failed++ == 0) first_error = r.error();
          return;  // the PLC's connection broke: that is the failure this test looks for
        }
        std::this_thread::sleep_for(200ms);
      }
    });
  }
  int finish() {
    stop = true;
    thread.join();
    return failed.load();
  }
};

}  // namespace

TEST_CASE("abuse over loopback: the cap and the allow-list hold and the PLC keeps working") {
  TempDir dir("abuse");
  const int port = free_port();
  const auto config = write_config(dir.path, "camera:\n  driver: replay\n  replay:\n    directory: " +
                                                 std::string(PALLETD_TEST_DATA_DIR) +
                                                 "\nmodbus:\n  bind_address: 127.0.0.1\n  port: " + std::to_string(port) +
                                                 "\n  allow: [127.0.0.1/32, 127.0.0.2/32]\n  read_only: [127.0.0.2/32]\n"
                                                 "  max_connections: 16\n  idle_timeout_s: 30\n"
                                                 "pipeline:\n  default_recipe: 6\nlogging:\n  level: info\n");
  NotifySocket notify;
  Daemon daemon({"--config", config.string()}, notify.path, dir.path / "palletd.log");
  REQUIRE(wait_ready(notify, daemon, scaled(10s)));
  const std::size_t fds_idle = daemon.open_fds();
  PlcLoop plc(port);
  for (int i = 0; i < 200 * PALLETD_TEST_TIME_SCALE && plc.ok == 0; ++i) std::this_thread::sleep_for(50ms);
  REQUIRE(plc.ok > 0);

  {
    // 1000 connections opened at once (non-blocking connects), held while the PLC triggers.
    REQUIRE(raise_fd_limit() >= 1100);
    std::vector<std::unique_ptr<RawClient>> burst;
    for (int i = 0; i < 1000; ++i) burst.push_back(raw(port, "127.0.0.1", /*nonblocking_connect=*/true));
    std::size_t connected = 0;
    for (const auto& c : burst) connected += c->connected() ? 1 : 0;
    CHECK(connected >= 900);
    const int ok_before = plc.ok;
    std::size_t fds_max = 0;
    // 2 s with the burst open (longer in sanitizer builds while the PLC has not got through).
    for (int i = 0; i < 40 || (i < 40 * PALLETD_TEST_TIME_SCALE && plc.ok == ok_before); ++i) {
      fds_max = std::max(fds_max, daemon.open_fds());
      std::this_thread::sleep_for(50ms);
    }
    INFO("daemon fds idle " << fds_idle << ", max during the burst " << fds_max);
    std::printf("1000 connections at once: %zu connected, daemon fds %zu idle, %zu at most during the burst; "
                "PLC handshakes during the burst: %d\n", connected, fds_idle, fds_max, plc.ok - ok_before);
    CHECK(fds_max <= fds_idle + 16 + 4);  // the cap (the PLC counts toward it), plus an accept and a frame read
    CHECK(plc.ok > ok_before);
    CHECK(plc.failed == 0);
  }

  {
    // Slow-byte senders: 8 clients trickle one request a byte every 30 ms; each gets its answer.
    std::vector<std::unique_ptr<RawClient>> slow;
    for (int i = 0; i < 8; ++i) slow.push_back(raw(port));
    const auto request = frame(77, pdu(3, kRegInterfaceVersion, 1));
    for (std::size_t b = 0; b < request.size(); ++b) {
      for (auto& c : slow) REQUIRE(c->send({request[b]}));
      std::this_thread::sleep_for(30ms);
    }
    for (auto& c : slow) {
      const auto r = c->receive(kAnswer);
      REQUIRE(r.size() == 11);
      CHECK(tid_of(r) == 77);
      CHECK(r[10] == 1);  // interface version
    }
  }

  {
    // Pipelined: 100 requests in one write, 100 answers in order.
    auto pipe = raw(port);
    std::vector<std::uint8_t> batch;
    for (std::uint16_t t = 0; t < 100; ++t) {
      const auto f = frame(static_cast<std::uint16_t>(1000 + t), pdu(4, kRegTestPattern, 2));
      batch.insert(batch.end(), f.begin(), f.end());
    }
    REQUIRE(pipe->send(batch));
    int in_order = 0;
    for (std::uint16_t t = 0; t < 100; ++t) {
      const auto r = pipe->receive(kAnswer);
      if (r.size() == 13 && tid_of(r) == 1000 + t && r[9] == 0x12 && r[10] == 0x34) ++in_order;
    }
    CHECK(in_order == 100);
  }

  {
    // Malformed MBAP headers and oversize lengths.
    auto other_protocol = raw(port);
    REQUIRE(other_protocol->send(frame(5, pdu(3, 108, 1), /*protocol=*/7)));
    CHECK(other_protocol->receive(300ms).empty());  // not Modbus: no answer
    REQUIRE(other_protocol->send(frame(6, pdu(3, 108, 1))));
    CHECK(tid_of(other_protocol->receive(kAnswer)) == 6);  // and the connection still serves
    for (const int length : {0, 1, 255, 0xFFFF}) {
      auto bad = raw(port);
      REQUIRE(bad->send(frame(8, pdu(3, 108, 1), 0, length)));
      INFO("length field " << length);
      CHECK(bad->closed_by_peer_drain(kAnswer));
    }
    // Oversize quantities and out-of-range addresses: exceptions 03 / 02.
    auto q = raw(port);
    REQUIRE(q->send(frame(9, pdu(3, 200, 126))));
    CHECK(exception_of(q->receive(kAnswer)) == 3);
    REQUIRE(q->send(frame(10, pdu(3, 950, 40))));  // past 974, the last register
    CHECK(exception_of(q->receive(kAnswer)) == 2);
    // FC16 announcing 124 registers (limit 123) with a byte count that does not match.
    REQUIRE(q->send(frame(11, {16, 0, 0, 0, 124, 2, 0, 0})));
    CHECK(exception_of(q->receive(kAnswer)) == 3);
    // Seeded random garbage: the daemon answers, drops or closes, but never stops serving the PLC.
    std::mt19937 rng(9);
    for (int i = 0; i < 50; ++i) {
      auto g = raw(port);
      std::vector<std::uint8_t> junk(static_cast<std::size_t>(8 + rng() % 300));
      for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
      if (i % 2 == 0) junk[2] = junk[3] = 0;  // half of them with protocol id 0
      (void)g->send(junk);
      (void)g->receive(20ms);
    }
  }

  {
    // Writes from the read-only address and from the PLC outside the control block: exception 02,
    // nothing changed. An unlisted address is closed without an answer.
    PlcClient reader("127.0.0.1", port, 1);
    REQUIRE(reader.connect());
    RegisterImage before{};
    REQUIRE(reader.read(kControlStart, kControlCount, before));
    auto ro = raw(port, "127.0.0.2");
    REQUIRE(ro->connected());
    REQUIRE(ro->send(frame(20, pdu(6, kRegRequestId, 4321))));
    CHECK(exception_of(ro->receive(kAnswer)) == 2);
    REQUIRE(ro->send(frame(21, pdu(6, kRegControlWord, kCtlTrigger))));
    CHECK(exception_of(ro->receive(kAnswer)) == 2);
    REQUIRE(ro->send(frame(22, pdu(3, kRegInterfaceVersion, 1))));
    const auto read_ok = ro->receive(kAnswer);
    CHECK((read_ok.size() == 11 && read_ok[10] == 1));  // reads are fine
    auto plc_side = raw(port);
    REQUIRE(plc_side->send(frame(23, pdu(6, kRegStatusWord, 0xFFFF))));
    CHECK(exception_of(plc_side->receive(kAnswer)) == 2);
    REQUIRE(plc_side->send(frame(24, pdu(6, kRegResultId, 7))));
    CHECK(exception_of(plc_side->receive(kAnswer)) == 2);
    RegisterImage after{};
    REQUIRE(reader.read(kControlStart, kControlCount, after));
    CHECK(after[kRegRequestId] != 4321);
    auto outsider = raw(port, "127.0.0.3");
    REQUIRE(outsider->connected());
    (void)outsider->send(frame(30, pdu(6, kRegControlWord, kCtlTrigger)));
    CHECK(outsider->receive(500ms).empty());
    CHECK(outsider->closed_by_peer_drain(kAnswer));
  }

  // The PLC went on throughout; one more handshake after the abuse, and the daemon is intact.
  const int ok_end = plc.ok;
  for (int i = 0; i < 12 * PALLETD_TEST_TIME_SCALE && plc.ok == ok_end; ++i) std::this_thread::sleep_for(50ms);
  CHECK(plc.ok > ok_end);
  INFO(plc.first_error);
  CHECK(plc.finish() == 0);
  CHECK(daemon.alive());
  CHECK(daemon.open_fds() <= fds_idle + 4);  // the PLC and a frame being read: no socket leaked
  const std::string log = daemon.log_text();
  CHECK(log.find("not on the allow list") != std::string::npos);
  CHECK(log.find("connection cap reached") != std::string::npos);
  ::kill(daemon.pid, SIGTERM);
  CHECK(daemon.wait_exit(scaled(3s)) == 0);
}
