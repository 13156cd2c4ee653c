// palletd sim: private helpers shared by the simulator's sources.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "palletd/sim/sim.hpp"

namespace palletd::sim::detail {

constexpr double kPi = 3.14159265358979323846;

/// SplitMix64 step: decorrelates seeds derived from one another.
inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30U)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27U)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31U);
}

/// Deterministic random numbers on every platform: mt19937_64 (fully specified by the standard)
/// with hand-written uniform and Box-Muller normal distributions.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(splitmix64(seed)) {}
  Rng(std::uint64_t seed, std::uint64_t stream) : engine_(splitmix64(splitmix64(seed) ^ stream)) {}

  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(engine_() >> 11U) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [0, n).
  std::size_t index(std::size_t n) {
    return n == 0 ? 0 : static_cast<std::size_t>(uniform() * static_cast<double>(n)) % n;
  }
  int integer(int lo, int hi) {  // inclusive
    return lo + static_cast<int>(index(static_cast<std::size_t>(hi - lo + 1)));
  }
  bool chance(double p) { return uniform() < p; }
  /// Standard normal (Box-Muller, both values used).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = uniform();
    while (u1 <= 1e-300) u1 = uniform();
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * kPi * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * kPi * u2);
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

/// A box footprint of a layer pattern before realism is applied, pallet frame [m].
struct PlacedBox {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double yaw_rad = 0.0;  ///< 0 or pi/2 (long side along x or y)
  int format = 0;        ///< index into the layer's formats
};

/// Nominal layout (no gaps) of one layer, its bounding box centred on the origin, inside
/// area_long x area_short. The realism (gaps, jitter, mirroring of lower layers) comes later.
std::vector<PlacedBox> make_pattern(PatternFamily family, const std::vector<BoxFormatSpec>& formats,
                                    double area_long_m, double area_short_m, Rng& rng);

/// The four corners of a footprint, counter-clockwise.
std::vector<Eigen::Vector2d> footprint_corners(const Eigen::Vector2d& center, double yaw_rad,
                                               double long_m, double short_m);
/// True when two footprints overlap by more than `tolerance_m`.
bool footprints_overlap(const SimBox& a, const SimBox& b, double tolerance_m = 1e-6);

/// Order in which a depalletizer removes the boxes (first = removed first).
std::vector<std::size_t> removal_order(const std::vector<SimBox>& layer, RemovalMode mode, Rng& rng);

}  // namespace palletd::sim::detail
