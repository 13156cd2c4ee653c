#include "aravis/depth_convert.hpp"

#include <cmath>
#include <cstring>

namespace palletd::aravis {

namespace {

std::uint16_t quantise(double z_m) {
  if (!(z_m > 0.0)) return 0;  // also NaN
  const double q = std::round(z_m / kQuantumM);
  if (q < 1.0 || q > 65535.0) return 0;
  return static_cast<std::uint16_t>(q);
}

}  // namespace

void convert_c16(const void* raw, std::size_t n, const Scan3dParams& p, Frame& out) {
  out.depth.resize(n);
  std::memcpy(out.depth.data(), raw, n * sizeof(std::uint16_t));
  const bool has_invalid = p.invalid.has_value() && *p.invalid >= 0.0 && *p.invalid <= 65535.0;
  const auto invalid = has_invalid ? static_cast<std::uint16_t>(*p.invalid) : std::uint16_t{0};
  if (p.offset == 0.0) {
    out.depth_scale_m = p.scale * p.unit_m;
    if (has_invalid && invalid != 0) {
      for (auto& d : out.depth) d = d == invalid ? std::uint16_t{0} : d;
    }
    return;
  }
  out.depth_scale_m = kQuantumM;
  for (auto& d : out.depth) {
    if (d == 0 || (has_invalid && d == invalid)) {
      d = 0;
      continue;
    }
    d = quantise((static_cast<double>(d) * p.scale + p.offset) * p.unit_m);
  }
}

void convert_abc32f(const void* raw, std::size_t n, const Scan3dParams& p, Frame& out) {
  out.depth.resize(n);
  out.depth_scale_m = kQuantumM;
  const auto* bytes = static_cast<const unsigned char*>(raw);
  for (std::size_t i = 0; i < n; ++i) {
    float z = 0.0f;
    std::memcpy(&z, bytes + i * 3 * sizeof(float) + 2 * sizeof(float), sizeof z);
    if (!std::isfinite(z) || (p.invalid && static_cast<double>(z) == *p.invalid)) {
      out.depth[i] = 0;
      continue;
    }
    out.depth[i] = quantise((static_cast<double>(z) * p.scale + p.offset) * p.unit_m);
  }
}

}  // namespace palletd::aravis
