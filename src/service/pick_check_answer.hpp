// The answer to the PLC's PickCheck: the result in the block checked against the frame after the
// pick, brought up to date without a layout search (palletd/detection/pick_check.hpp).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "palletd/config/config.hpp"
#include "palletd/detection/pick_check.hpp"
#include "palletd/modbus/handshake.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/status/snapshot.hpp"

namespace palletd {

/// The boxes registers 4 and 5 name (slot + 1 of a box, of a group; 0 = none) as indices into
/// `last.boxes`; empty when they name none of this result's reported boxes or groups.
std::vector<int> picked_boxes(const Detection& last, std::uint16_t picked_box, std::uint16_t picked_group);

/// Why a PickCheck cannot run: the register-102 detail and the words; empty when it can.
using CheckRefusal = std::optional<std::pair<modbus::PickCheckFailure, std::string>>;
/// `last` (the result in the block) failed, has no boxes or no frame, or `picked` (what registers
/// 4 and 5 of `event` name) is empty.
CheckRefusal refuse_check(const ResultSnapshot* last, const std::vector<int>& picked,
                          const modbus::HandshakeEvent& event);

struct CheckAnswer {
  PickCheck check;
  Detection detection;          ///< the layout after the pick (`last`'s when the check failed)
  modbus::ResultRecord record;  ///< with `check` set; status kFailed when the check could not run
  std::string error_text;       ///< "" when the check ran
};

/// Checks `last` (checkable) against `after` and answers the PLC.
CheckAnswer answer_pick_check(const ResultSnapshot& last, const Frame& after, const std::vector<int>& picked,
                              const Config& cfg);

}  // namespace palletd
