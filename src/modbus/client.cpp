#include "palletd/modbus/client.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <thread>

#include <modbus/modbus.h>

namespace palletd::modbus {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

struct PlcClient::Context {
  modbus_t* ctx = nullptr;
  bool connected = false;
  ~Context() {
    if (ctx == nullptr) return;
    if (connected) modbus_close(ctx);
    modbus_free(ctx);
  }
};

PlcClient::PlcClient(std::string host, int port, int unit_id)
    : host_(std::move(host)), port_(port), unit_id_(unit_id), ctx_(std::make_unique<Context>()) {}

PlcClient::~PlcClient() = default;

Status PlcClient::connect() {
  const std::string service = std::to_string(port_);
  ctx_->ctx = modbus_new_tcp_pi(host_.c_str(), service.c_str());
  if (ctx_->ctx == nullptr) return Error{"modbus: cannot create a client for " + host_ + ":" + service};
  modbus_set_slave(ctx_->ctx, unit_id_);
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(response_timeout_).count();
  modbus_set_response_timeout(ctx_->ctx, static_cast<std::uint32_t>(us / 1000000),
                              static_cast<std::uint32_t>(us % 1000000));
  if (modbus_connect(ctx_->ctx) != 0)
    return Error{"modbus: cannot connect to " + host_ + " port " + service + ": " + modbus_strerror(errno)};
  ctx_->connected = true;
  return {};
}

Status PlcClient::read(std::uint16_t start, std::uint16_t count, RegisterImage& image) {
  std::uint16_t done = 0;
  while (done < count) {
    const auto n = static_cast<std::uint16_t>(std::min<int>(125, count - done));
    const int address = start + done;
    if (modbus_read_registers(ctx_->ctx, address, n, &image[address]) != n)
      return Error{"modbus: reading registers " + std::to_string(address) + ".." + std::to_string(address + n - 1) +
                   ": " + modbus_strerror(errno)};
    done = static_cast<std::uint16_t>(done + n);
  }
  return {};
}

Status PlcClient::write(std::uint16_t start, const std::uint16_t* values, std::uint16_t count) {
  if (modbus_write_registers(ctx_->ctx, start, count, values) != count)
    return Error{"modbus: writing registers " + std::to_string(start) + ".." + std::to_string(start + count - 1) +
                 ": " + modbus_strerror(errno)};
  return {};
}

Expected<std::uint16_t> PlcClient::read_status_word() {
  std::uint16_t word = 0;
  if (modbus_read_registers(ctx_->ctx, kRegStatusWord, 1, &word) != 1)
    return Error{std::string("modbus: reading the status word: ") + modbus_strerror(errno)};
  return word;
}

Status PlcClient::wait_status(std::uint16_t mask, std::uint16_t want, Clock::time_point deadline, const char* what) {
  for (;;) {
    Expected<std::uint16_t> word = read_status_word();
    if (!word) return Error{word.error()};
    if ((*word & mask) == want) return {};
    if (Clock::now() >= deadline) return Error{std::string("timed out waiting for ") + what};
    std::this_thread::sleep_for(5ms);
  }
}

Expected<PlcClient::TriggerResult> PlcClient::trigger(std::uint16_t recipe, std::uint16_t request_id,
                                                      std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  if (Status s = wait_status(kStReady | kStBusy, kStReady, deadline, "Ready and not Busy"); !s)
    return Error{s.error()};
  const std::uint16_t latched[2] = {recipe, request_id};
  if (Status s = write(kRegRecipe, latched, 2); !s) return Error{s.error()};
  return run_handshake(kCtlTrigger, request_id, deadline);
}

Expected<PlcClient::TriggerResult> PlcClient::pick_check(std::uint16_t picked_box, std::uint16_t picked_group,
                                                         std::uint16_t request_id, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  if (Status s = wait_status(kStReady | kStBusy, kStReady, deadline, "Ready and not Busy"); !s)
    return Error{s.error()};
  const std::uint16_t picked[2] = {picked_box, picked_group};
  if (Status s = write(kRegPickedBox, picked, 2); !s) return Error{s.error()};
  if (Status s = write(kRegRequestId, &request_id, 1); !s) return Error{s.error()};
  return run_handshake(kCtlPickCheck, request_id, deadline);
}

Expected<PlcClient::TriggerResult> PlcClient::run_handshake(std::uint16_t control_bit, std::uint16_t request_id,
                                                            Clock::time_point deadline) {
  const auto t0 = Clock::now();
  if (Status s = write(kRegControlWord, &control_bit, 1); !s) return Error{s.error()};
  if (Status s = wait_status(kStTriggerAck, kStTriggerAck, deadline, "TriggerAck"); !s)
    return Error{s.error()};
  const std::uint16_t zero = 0;
  if (Status s = write(kRegControlWord, &zero, 1); !s) return Error{s.error()};

  TriggerResult out;
  RegisterImage image{};
  for (;;) {
    if (Status s = wait_status(kStResultReady, kStResultReady, deadline, "ResultReady"); !s)
      return Error{s.error()};
    out.handshake_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (Status s = read(kStatusStart, kStatusCount, image); !s) return Error{s.error()};
    out.word_order = (image[kRegFormatFlags] & kFmtLowWordFirst) != 0
                         ? WordOrder::kLowWordFirst
                         : WordOrder::kHighWordFirst;
    if (Status s = read(kResultExtStart, kResultExtCount, image); !s) return Error{s.error()};
    if (Status s = read(kResultStart, kResultCount, image); !s) return Error{s.error()};
    if (Status s = read(kPickStart, kPickCount, image); !s) return Error{s.error()};
    if (Status s = read(kSizeStart, kSizeCount, image); !s) return Error{s.error()};
    out.result = decode_result(image, out.word_order);
    out.status = decode_status(image, out.word_order);
    // Several reads belong together only when the result id in 200, 530, 540, 902 and 974 agrees.
    if (out.result.ids_agree() && out.result.record.request_id == request_id) break;
    if (Clock::now() >= deadline) return Error{"timed out waiting for the result of request " +
                                               std::to_string(request_id)};
  }
  const std::uint16_t ack = kCtlResultAck;
  if (Status s = write(kRegControlWord, &ack, 1); !s) return Error{s.error()};
  if (Status s = wait_status(kStResultReady, 0, deadline, "ResultReady to clear"); !s) return Error{s.error()};
  if (Status s = write(kRegControlWord, &zero, 1); !s) return Error{s.error()};
  return out;
}

}  // namespace palletd::modbus
