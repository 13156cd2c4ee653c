// palletd core: the stage timings a result carries (Detection::timing_ms and the like).
#pragma once

#include <chrono>

namespace palletd {

/// Milliseconds of the steady clock since `t0`.
inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace palletd
