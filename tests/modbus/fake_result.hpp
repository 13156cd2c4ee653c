// Test fixture: the deterministic fake detection the test server answers a trigger with.
// tests/modbus/handshake_client.py and handshake_client.mjs compute the same numbers to check
// what they decode; keep the three in step.
#pragma once

#include <cstdint>

#include "palletd/modbus/register_map.hpp"

namespace palletd::modbus::test {

/// recipe 0 -> no boxes; recipe 99 -> failed (no layout); else `recipe` boxes (at most 40, of
/// which 32 are reported).
inline ResultRecord fake_result(std::uint16_t recipe, std::uint16_t request_id) {
  ResultRecord r;
  r.recipe = recipe;
  r.request_id = request_id;
  r.processing_ms = 12.0;
  if (recipe == 99) {
    r.status = ResultStatus::kFailed;
    r.error = ErrorCode::kDetectionFailed;
    r.error_detail = static_cast<std::uint16_t>(DetectionFailure::kNoLayout);
    return r;
  }
  const int n = recipe > 40 ? 40 : recipe;
  r.status = n == 0 ? ResultStatus::kNoBoxes : ResultStatus::kOk;
  r.boxes_found = static_cast<std::uint16_t>(n);
  r.layer_z_m = -1.5 + 0.0001 * request_id;
  r.coverage = 0.875;
  r.ambiguous = (request_id % 2) == 1;
  for (int i = 0; i < n; ++i) {
    BoxRecord b;
    b.x_m = (request_id % 100) * 0.01 - 0.5 + 0.1 * i;
    b.y_m = -0.3 - 0.0123 * i;
    b.z_m = 1.2345;
    b.yaw_deg = -179.0 + 7.5 * i;
    b.format = static_cast<std::uint16_t>(i % 3);
    b.score = ((i * 37) % 1000) / 1000.0;
    b.pick_index = static_cast<std::uint16_t>(i + 1);
    r.boxes.push_back(b);
  }
  return r;
}

}  // namespace palletd::modbus::test
