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

constexpr double kPalletHeight_m = 0.144;  ///< EUR and industrial pallets [m]

/// A plain cuboid part of the scene (pallet wood, cell furniture): no bulge, bevel or patches,
/// not a box of the load (format_index -1).
SimBox cuboid(const Eigen::Vector2d& center, double yaw_rad, double long_m, double short_m, double bottom_z_m,
              double top_z_m, double reflectance);

/// Adds a pallet's parts centred at `center` (x along its long side): top deck boards with gaps,
/// three cross boards, nine blocks, three bottom boards; or, with `solid_deck`, the deck as one
/// slab over three solid rows of blocks (the model before issue 19).
void add_pallet(Scene& scene, const Eigen::Vector2d& center, bool solid_deck);

/// Lays a slip sheet (with curled edge strips) whose underside is at `bottom_z_m` over the
/// pallet; returns the height of its top face [m]. Its parts have format_index -1.
double add_slip_sheet(Scene& scene, double bottom_z_m, Rng& rng);

/// What the cell's surroundings are sized from.
struct CellInput {
  double load_top_z_m = 0.0;      ///< top of the full load [m]
  int max_stack_layers = 1;       ///< layers the second stack may have
  BoxFormatSpec stack_format;     ///< format of the second stack's boxes
  bool solid_deck = false;
};
/// Adds a cabinet (always, taller than the load), and by chance fence posts, a roller conveyor at
/// pallet height and a second lower stack, each on its own side of the pallet, outside the
/// region of interest; records them in Scene::surroundings (the cabinet first).
void add_surroundings(Scene& scene, const CellInput& input, Rng& rng);

/// Pallet stops: square posts 60-100 mm thick beside one to four of the pallet's sides, 20-60 mm
/// off its edge, their tops 0.05-0.4 m above the load (a pallet station's centring guides). They
/// stand inside the region of interest and higher than the layer: the gripper must keep clear.
/// Recorded in Scene::stops.
void add_pallet_stops(Scene& scene, double load_top_z_m, Rng& rng);

/// Active stereo: for each pixel (row-major, depth z [m], 0 = none) the pixel whose surface the
/// block matching reports there: itself, or the closest pixel within a window whose reach is drawn
/// per pixel in 1..max_px that lies more than 1 cm nearer. Foreground thus grows by 1-2 pixels
/// (ragged) and seams up to about two pixels wide fill at the depth beside them; no depth is mixed.
std::vector<std::size_t> stereo_sources(const std::vector<double>& z, int w, int h, int max_px, Rng& rng);

/// True when a part of the surroundings lies between the camera and one of the world points.
bool surroundings_hide(const Scene& scene, const std::vector<Eigen::Vector3d>& points_world);

/// Which pattern, profile and scene (indices into generate_set's lists) a frame shows.
struct Combination {
  std::size_t pattern = 0, profile = 0, scene = 0;
};
/// The combinations of `count` frames: every one of patterns x profiles x scenes once per round
/// of that many frames, in an order shuffled per round from `seed`, so that no pattern is always
/// seen by the same camera (cycling each list by the frame index pairs the k-th pattern with the
/// k-th profile whenever the lists are as long).
std::vector<Combination> frame_combinations(std::size_t patterns, std::size_t profiles, std::size_t scenes,
                                            std::uint64_t seed, std::size_t count);

}  // namespace palletd::sim::detail
