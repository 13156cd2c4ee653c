// The Modbus TCP server against real clients over loopback: libmodbus as the client for the
// function codes, hand-made frames (raw_client.hpp) for what libmodbus will not send. Connection
// limits, address lists, timeouts and the server's life cycle: test_server_connections.cpp.
#include <atomic>
#include <cerrno>
#include <thread>

#include "raw_client.hpp"
#include "server_fixture.hpp"

using namespace palletd::modbus;
using namespace palletd::modbus::test;
using std::chrono::milliseconds;

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
  CHECK(modbus_read_registers(c.ctx, 531, 2, many) == 2);              // the best recipe and across the gap 533..539
  CHECK(modbus_read_input_registers(c.ctx, 778, 125, many) == 125);  // up to 902
  CHECK(modbus_read_registers(c.ctx, 850, 125, many) == 125);        // up to 974, the size block's end
  CHECK(modbus_read_registers(c.ctx, 974, 2, many) == -1);
  CHECK(errno == EMBXILADD);
  CHECK(modbus_read_input_registers(c.ctx, kRegisterCount, 1, many) == -1);
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
  CHECK(c.reg(kRegPickResultId) == 1);
  CHECK(c.reg(kRegPickFlags) == 0);  // no gripper
  CHECK(c.reg(kPickIdCopy) == 1);
  REQUIRE(modbus_write_register(c.ctx, 0, kCtlResultAck) == 1);
  CHECK((c.reg(kRegStatusWord) & kStResultReady) == 0);
  CHECK(s.server.registers()[kRegResultId] == 1);
}

TEST_CASE("the pick block over the wire: header, groups and box pick statuses in 540..902",
          "[modbus][server]") {
  Server s;
  Client c("127.0.0.1", s.port());
  REQUIRE(c.connected);
  auto result = std::make_shared<ResultRecord>();
  result->boxes_found = 3;
  for (int i = 0; i < 3; ++i)
    result->boxes.push_back(BoxRecord{0.1 * i, 0.5, 1.25, 90.0, 0, 0.75, static_cast<std::uint16_t>(i + 1)});
  result->boxes[2].pick_status = PickStatus::kHigherLevel;
  result->picking = true;
  result->groups.push_back(GroupRecord{0.05, 0.5, 1.3, -45.0, 2, 0, 1});
  result->groups_found = 1;
  result->pickable_boxes = 2;
  s.server.publish_result(result);
  REQUIRE(wait_bits(c, kRegStatusWord, kStResultReady, kStResultReady));
  std::uint16_t head[kPickHeaderCount + kGroupStride] = {};
  REQUIRE(modbus_read_registers(c.ctx, kPickStart, 20, head) == 20);
  CHECK(head[0] == 1);             // result id
  CHECK(head[1] == kPickGripper);  // pick flags
  CHECK(head[2] == 1);             // groups found
  CHECK(head[3] == 1);             // groups reported
  CHECK(head[4] == 2);             // pickable boxes
  CHECK(get_i32(head + 10, WordOrder::kHighWordFirst) == 500);
  CHECK(get_i32(head + 14, WordOrder::kHighWordFirst) == 13000);
  CHECK(head[16] == static_cast<std::uint16_t>(-4500));
  CHECK(head[17] == 2);  // box count
  CHECK(head[18] == 0);  // first box slot
  CHECK(head[19] == 1);  // pick index
  std::uint16_t tail[kMaxBoxes + 1] = {};
  REQUIRE(modbus_read_input_registers(c.ctx, kPickStatusStart, kMaxBoxes + 1, tail) == kMaxBoxes + 1);
  CHECK(tail[0] == 0);
  CHECK(tail[1] == 0);
  CHECK(tail[2] == 2);  // higher level
  CHECK(tail[3] == 0);  // unused slot
  CHECK(tail[kMaxBoxes] == 1);  // 902: result id copy
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
  CHECK(exception_of(ask(RawClient::read_pdu(3, 500, 32))) == 0);
  CHECK(exception_of(ask(RawClient::read_pdu(3, 778, 125))) == 0);
  CHECK(exception_of(ask(RawClient::read_pdu(3, 850, 125))) == 0);
  CHECK(exception_of(ask(RawClient::read_pdu(3, 851, 125))) == 2);
  CHECK(exception_of(ask(RawClient::read_pdu(4, 975, 1))) == 2);
  CHECK(exception_of(ask(RawClient::read_pdu(1, 0, 2001))) == 3);
  CHECK(exception_of(ask({5, 0, 0, 0x12, 0x34})) == 3);  // coil value neither 0 nor FF00
  CHECK(exception_of(ask({0x07})) == 1);
  CHECK(exception_of(ask({0x11})) == 1);
  CHECK(exception_of(ask({0x2B, 0x0E, 0x01, 0x00})) == 1);
  CHECK(exception_of(ask({3, 0, 0})) == 3);  // truncated PDU
  // Function codes with the top bit set: exception 01, the function byte kept as 0x80 | fc (not
  // wrapped to fc + 0x80 in 8 bits, which would read as an ordinary reply to fc - 0x80).
  for (const std::uint8_t fc : {std::uint8_t{0x80}, std::uint8_t{0x83}, std::uint8_t{0x90},
                                std::uint8_t{0xFF}}) {
    const auto reply = ask({fc, 0, 0, 0, 1});
    REQUIRE(reply.size() == 9);
    CHECK(reply[4] == 0);
    CHECK(reply[5] == 3);    // length: unit id + function + code
    CHECK(reply[6] == 1);    // unit id echoed
    CHECK(reply[7] == fc);   // 0x80 | fc
    CHECK(reply[8] == 1);    // illegal function
  }
  CHECK(ask({3, 0, 108, 0, 1}).size() == 11);  // the connection still answers
  // Counted per code: 01 for 0x07, 0x11, 0x2B and the four above (the copy follows within a loop).
  for (int i = 0; i < 100 && s.server.stats().exceptions_by_code[1] < 7; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  CHECK(s.server.stats().exceptions_by_code[1] == 7);
  CHECK(s.server.stats().exceptions_by_code[3] >= 5);

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

TEST_CASE("the health block and its status bits over the wire, SetDriftReference through coil 4",
          "[modbus][server]") {
  Server s;
  Client c("127.0.0.1", s.port());
  REQUIRE(c.connected);
  auto status = std::make_shared<ServiceStatus>();
  status->ready = true;
  status->camera_ok = true;
  status->health.flags = kHealthDrift | kHealthDriftReference | kHealthDriftMeasured;
  status->health.frames = 7;
  status->health.drift_shift_mm = 15.0;
  s.server.publish_status(status);
  REQUIRE(wait_bits(c, kRegStatusWord, kStDriftWarning, kStDriftWarning));
  std::uint16_t block[kHealthCount] = {};
  REQUIRE(modbus_read_registers(c.ctx, kHealthStart, kHealthCount, block) == kHealthCount);
  CHECK(block[0] == status->health.flags);
  CHECK(block[1] == 7);
  CHECK(block[kRegDriftShift - kHealthStart] == 150);
  std::uint8_t inputs[16] = {};
  REQUIRE(modbus_read_input_bits(c.ctx, 0, 16, inputs) == 16);
  CHECK(inputs[9] == 0);   // HealthWarning
  CHECK(inputs[10] == 1);  // DriftWarning
  // The block is read-only like the rest of the status block.
  CHECK(modbus_write_register(c.ctx, kHealthStart, 1) == -1);

  REQUIRE(modbus_write_bit(c.ctx, 4, 1) == 1);
  const auto event = s.server.wait_event(milliseconds(2000));
  REQUIRE(event.has_value());
  CHECK(event->kind == EventKind::kSetDriftReference);
}
