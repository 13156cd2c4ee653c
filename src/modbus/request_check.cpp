#include "request_check.hpp"

#include "palletd/modbus/register_map.hpp"

namespace palletd::modbus::detail {
namespace {

// Coils 0..15 are the bits of the control word (register 0); discrete inputs 0..15 are the bits
// of the status word (register 100).
constexpr unsigned kBitCount = 16;
constexpr unsigned kMaxReadBits = 2000;
constexpr unsigned kMaxWriteBits = 1968;
constexpr unsigned kMaxReadRegisters = 125;
constexpr unsigned kMaxWriteRegisters = 123;
constexpr unsigned kMaxRwWriteRegisters = 121;

bool in_range(unsigned address, unsigned count, unsigned limit) { return address + count <= limit; }

}  // namespace

bool is_write_function(std::uint8_t function) {
  return function == kWriteSingleCoil || function == kWriteSingleRegister ||
         function == kWriteMultipleCoils || function == kWriteMultipleRegisters ||
         function == kReadWriteMultipleRegisters;
}

std::uint8_t check_request(const std::uint8_t* pdu, std::size_t n, bool read_only) {
  if (n < 1) return kExIllegalFunction;
  const std::uint8_t function = pdu[0];
  std::uint8_t address_error = 0;
  switch (function) {
    case kReadCoils:
    case kReadDiscreteInputs: {
      if (n != 5) return kExIllegalValue;
      const unsigned address = u16(pdu + 1), count = u16(pdu + 3);
      if (count < 1 || count > kMaxReadBits) return kExIllegalValue;
      return in_range(address, count, kBitCount) ? 0 : kExIllegalAddress;
    }
    case kReadHoldingRegisters:
    case kReadInputRegisters: {
      if (n != 5) return kExIllegalValue;
      const unsigned address = u16(pdu + 1), count = u16(pdu + 3);
      if (count < 1 || count > kMaxReadRegisters) return kExIllegalValue;
      return in_range(address, count, kRegisterCount) ? 0 : kExIllegalAddress;
    }
    case kWriteSingleCoil: {
      if (n != 5) return kExIllegalValue;
      const unsigned address = u16(pdu + 1), value = u16(pdu + 3);
      if (value != 0xFF00 && value != 0x0000) return kExIllegalValue;
      address_error = in_range(address, 1, kBitCount) ? 0 : kExIllegalAddress;
      break;
    }
    case kWriteSingleRegister: {
      if (n != 5) return kExIllegalValue;
      address_error = in_range(u16(pdu + 1), 1, kControlCount) ? 0 : kExIllegalAddress;
      break;
    }
    case kWriteMultipleCoils: {
      if (n < 6) return kExIllegalValue;
      const unsigned address = u16(pdu + 1), count = u16(pdu + 3), bytes = pdu[5];
      if (count < 1 || count > kMaxWriteBits || bytes != (count + 7) / 8 || n != 6 + bytes) {
        return kExIllegalValue;
      }
      address_error = in_range(address, count, kBitCount) ? 0 : kExIllegalAddress;
      break;
    }
    case kWriteMultipleRegisters: {
      if (n < 6) return kExIllegalValue;
      const unsigned address = u16(pdu + 1), count = u16(pdu + 3), bytes = pdu[5];
      if (count < 1 || count > kMaxWriteRegisters || bytes != 2 * count || n != 6 + bytes) {
        return kExIllegalValue;
      }
      address_error = in_range(address, count, kControlCount) ? 0 : kExIllegalAddress;
      break;
    }
    case kReadWriteMultipleRegisters: {
      if (n < 10) return kExIllegalValue;
      const unsigned read_address = u16(pdu + 1), read_count = u16(pdu + 3);
      const unsigned write_address = u16(pdu + 5), write_count = u16(pdu + 7), bytes = pdu[9];
      if (read_count < 1 || read_count > kMaxReadRegisters || write_count < 1 ||
          write_count > kMaxRwWriteRegisters || bytes != 2 * write_count || n != 10 + bytes) {
        return kExIllegalValue;
      }
      if (!in_range(read_address, read_count, kRegisterCount) ||
          !in_range(write_address, write_count, kControlCount)) {
        address_error = kExIllegalAddress;
      }
      break;
    }
    default:
      return kExIllegalFunction;
  }
  if (address_error != 0) return address_error;
  return read_only ? kExIllegalAddress : 0;
}

}  // namespace palletd::modbus::detail
