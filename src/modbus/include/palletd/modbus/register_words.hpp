// palletd modbus: register contents in words, for people reading the registers (the status page,
// `palletctl watch`). docs/register-map.md is the reference these words follow.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "palletd/modbus/register_map.hpp"

namespace palletd::modbus {

/// Short name of an error code (register 101): "frame timeout", "detection failed", ...
const char* error_name(ErrorCode code);
/// A sentence with the detail (register 102): "The detection failed: no plane found in the frame."
std::string error_sentence(ErrorCode code, std::uint16_t detail);
/// Names of the status word bits (register 100), bit 0 first: "Ready", "Busy", ...
const std::vector<std::string>& status_bit_names();
/// Names of the control word bits (register 0), bit 0 first: "Trigger", "ResultAck", ...
const std::vector<std::string>& control_bit_names();
/// The set bits of a word by name ("Ready, CameraOK"), or "none set".
std::string bits_in_words(std::uint16_t word, const std::vector<std::string>& names);

}  // namespace palletd::modbus
