// A minimal PLC over Modbus TCP (libmodbus client): the handshake of docs/register-map.md done
// once, as a PLC program would. Used by `palletctl trigger` and `palletctl watch`.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "palletd/core/expected.hpp"
#include "palletd/modbus/register_map.hpp"

namespace palletd::modbus {

class PlcClient {
 public:
  PlcClient(std::string host, int port, int unit_id);
  ~PlcClient();
  PlcClient(const PlcClient&) = delete;
  PlcClient& operator=(const PlcClient&) = delete;

  /// How long one request waits for its reply (default 2 s, applied by connect()). Tests under a
  /// sanitizer stretch it with their other time bounds.
  void set_response_timeout(std::chrono::milliseconds timeout) { response_timeout_ = timeout; }
  Status connect();
  /// Reads registers [start, start + count) (holding registers, split into reads of at most 125).
  Status read(std::uint16_t start, std::uint16_t count, RegisterImage& image);
  Status write(std::uint16_t start, const std::uint16_t* values, std::uint16_t count);

  struct TriggerResult {
    DecodedResult result;
    StatusRecord status;   ///< status block read with the result
    WordOrder word_order = WordOrder::kHighWordFirst;
    double handshake_ms = 0.0;     ///< trigger written to ResultReady seen [ms]
  };
  /// Waits for Ready and not Busy, triggers with `recipe` and `request_id`, waits for the result,
  /// reads it consistently (result id in 200, 530, 540 and 902 agree), acknowledges it.
  Expected<TriggerResult> trigger(std::uint16_t recipe, std::uint16_t request_id, std::chrono::milliseconds timeout);
  /// The same handshake with PickCheck after a pick: writes the picked box and group (slot + 1,
  /// 0 = none) to registers 4 and 5 and the request id to 2, raises PickCheck.
  Expected<TriggerResult> pick_check(std::uint16_t picked_box, std::uint16_t picked_group, std::uint16_t request_id,
                                     std::chrono::milliseconds timeout);

 private:
  Expected<std::uint16_t> read_status_word();
  /// Raises `control_bit` (registers 1.. already written), waits for the result of `request_id`,
  /// reads it and acknowledges it.
  Expected<TriggerResult> run_handshake(std::uint16_t control_bit, std::uint16_t request_id,
                                        std::chrono::steady_clock::time_point deadline);
  Status wait_status(std::uint16_t mask, std::uint16_t want, std::chrono::steady_clock::time_point deadline,
                     const char* what);

  std::string host_;
  int port_;
  int unit_id_;
  std::chrono::milliseconds response_timeout_{2000};
  struct Context;
  std::unique_ptr<Context> ctx_;
};

}  // namespace palletd::modbus
