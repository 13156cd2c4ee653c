// palletd modbus (private): validation of one Modbus request PDU against the register map, done
// before libmodbus sees it (modbus_reply sleeps and flushes on its own error paths).
#pragma once

#include <cstddef>
#include <cstdint>

namespace palletd::modbus::detail {

inline constexpr std::size_t kMbapLength = 7;          ///< transaction, protocol, length, unit
inline constexpr std::size_t kMaxPduLength = 253;
inline constexpr std::uint8_t kExIllegalFunction = 0x01;
inline constexpr std::uint8_t kExIllegalAddress = 0x02;
inline constexpr std::uint8_t kExIllegalValue = 0x03;
inline constexpr std::uint8_t kExGatewayTargetFailed = 0x0B;

/// Function codes this server answers.
enum FunctionCode : std::uint8_t {
  kReadCoils = 1,
  kReadDiscreteInputs = 2,
  kReadHoldingRegisters = 3,
  kReadInputRegisters = 4,
  kWriteSingleCoil = 5,
  kWriteSingleRegister = 6,
  kWriteMultipleCoils = 15,
  kWriteMultipleRegisters = 16,
  kReadWriteMultipleRegisters = 23,
};

/// A big-endian 16-bit field of a Modbus frame.
inline unsigned u16(const std::uint8_t* p) { return (static_cast<unsigned>(p[0]) << 8) | p[1]; }

/// 0 when the request is valid and may go to modbus_reply, else the exception code to answer.
/// Order of checks as in the Modbus application protocol: function (01), quantity and
/// framing (03), address (02); then writes from read-only clients (02).
std::uint8_t check_request(const std::uint8_t* pdu, std::size_t pdu_length, bool read_only);

/// Whether the function code writes (5, 6, 15, 16, 23).
bool is_write_function(std::uint8_t function);

}  // namespace palletd::modbus::detail
