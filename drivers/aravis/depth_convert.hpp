// Pixel conversions of the Aravis driver, free of Aravis types so they are tested on their own.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>

#include "palletd/core/frame.hpp"

namespace palletd::aravis {

/// GenICam Scan3d description of the depth coordinate (CoordinateC).
struct Scan3dParams {
  double scale = 1.0;              ///< Scan3dCoordinateScale [distance unit per raw unit]
  double offset = 0.0;             ///< Scan3dCoordinateOffset [distance unit]
  double unit_m = 0.001;           ///< Scan3dDistanceUnit in metres (Millimeter = 0.001)
  std::optional<double> invalid;   ///< Scan3dInvalidDataValue (raw), when the camera has one
};

/// Quantisation of float / offset depth: 0.1 mm, covering 6.5535 m (include/palletd/core/frame.hpp).
inline constexpr double kQuantumM = 1e-4;

/// Coord3D_C16 / Mono16: `n` little-endian 16-bit values (any alignment). Without an offset the
/// raw values are kept as they are with depth_scale_m = scale * unit_m; with an offset depth is
/// converted to 0.1 mm units. Invalid values (and raw 0) become 0.
void convert_c16(const void* raw, std::size_t n, const Scan3dParams& p, Frame& out);

/// Coord3D_ABC32f: `n` pixels of three little-endian floats (X, Y, Z, any alignment). Z is
/// scaled, offset and quantised to 0.1 mm; NaN, non-positive, invalid or beyond 6.5535 m -> 0.
void convert_abc32f(const void* raw, std::size_t n, const Scan3dParams& p, Frame& out);

}  // namespace palletd::aravis
