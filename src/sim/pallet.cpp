// palletd sim: the pallet's wooden parts and the slip sheet (docs/simulator.md, "Scene").
#include <algorithm>
#include <cmath>

#include "sim_internal.hpp"

namespace palletd::sim::detail {
namespace {

constexpr double kBoardThickness_m = 0.022;
constexpr double kBlockHeight_m = 0.078;
constexpr double kWoodReflectance = 0.4;
constexpr double kBlockReflectance = 0.35;

/// The deck as one slab over three solid rows of blocks along the long side.
void add_solid_pallet(Scene& scene, const Eigen::Vector2d& center) {
  const double deck_bottom_m = kPalletHeight_m - kBoardThickness_m;
  scene.boxes.push_back(cuboid(center, 0.0, scene.pallet_long_m, scene.pallet_short_m, deck_bottom_m,
                               kPalletHeight_m, kWoodReflectance));
  for (int k = -1; k <= 1; ++k) {
    const Eigen::Vector2d row(0.0, k * (0.5 * scene.pallet_short_m - 0.0725));
    scene.boxes.push_back(
        cuboid(row + center, 0.0, scene.pallet_long_m, 0.145, 0.0, deck_bottom_m, kBlockReflectance));
  }
}

/// Widths of the top deck boards across the pallet [m]: 145/100 alternating, 5 boards on a
/// 800 mm wide pallet, 7 on a 1000 mm one.
std::vector<double> deck_board_widths(double short_m) {
  const int count = short_m > 0.9 ? 7 : 5;
  std::vector<double> widths;
  for (int i = 0; i < count; ++i) widths.push_back(i % 2 == 0 ? 0.145 : 0.100);
  return widths;
}

}  // namespace

SimBox cuboid(const Eigen::Vector2d& center, double yaw_rad, double long_m, double short_m, double bottom_z_m,
              double top_z_m, double reflectance) {
  SimBox b;
  b.center = center;
  b.yaw_rad = yaw_rad;
  b.long_m = long_m;
  b.short_m = short_m;
  b.bottom_z_m = bottom_z_m;
  b.top_z_m = top_z_m;
  b.reflectance = reflectance;
  return b;
}

void add_pallet(Scene& scene, const Eigen::Vector2d& center, bool solid_deck) {
  if (scene.pallet == PalletKind::kNone) return;
  if (solid_deck) {
    add_solid_pallet(scene, center);
    return;
  }
  const double hl = 0.5 * scene.pallet_long_m, hs = 0.5 * scene.pallet_short_m;
  const double z_deck = kPalletHeight_m - kBoardThickness_m;  // underside of the top deck
  const double z_cross = z_deck - kBoardThickness_m;          // underside of the cross boards
  const double z_blocks = kBoardThickness_m;                  // underside of the blocks
  // Top deck: boards along the long side, the gaps between them equal.
  const std::vector<double> widths = deck_board_widths(scene.pallet_short_m);
  double covered_m = 0.0;
  for (double w : widths) covered_m += w;
  const double gap_m = (scene.pallet_short_m - covered_m) / static_cast<double>(widths.size() - 1);
  double y = -hs;
  for (double w : widths) {
    scene.boxes.push_back(cuboid(center + Eigen::Vector2d(0.0, y + 0.5 * w), 0.0, scene.pallet_long_m, w,
                                 z_deck, kPalletHeight_m, kWoodReflectance));
    y += w + gap_m;
  }
  // Cross boards and blocks at both ends and in the middle; bottom boards under the block rows.
  const double xs[3] = {-(hl - 0.0725), 0.0, hl - 0.0725};
  const double ys[3] = {-(hs - 0.0725), 0.0, hs - 0.0725};
  for (double x : xs)
    scene.boxes.push_back(cuboid(center + Eigen::Vector2d(x, 0.0), 0.5 * kPi, scene.pallet_short_m, 0.145,
                                 z_cross, z_deck, kWoodReflectance));
  for (double x : xs)
    for (double yb : ys)
      scene.boxes.push_back(
          cuboid(center + Eigen::Vector2d(x, yb), 0.0, 0.145, 0.145, z_blocks, z_cross, kBlockReflectance));
  for (double yb : ys)
    scene.boxes.push_back(cuboid(center + Eigen::Vector2d(0.0, yb), 0.0, scene.pallet_long_m,
                                 yb == 0.0 ? 0.100 : 0.145, 0.0, z_blocks, kWoodReflectance));
}

double add_slip_sheet(Scene& scene, double bottom_z_m, Rng& rng) {
  const double thickness_m = rng.uniform(0.001, 0.003);
  const double rho = rng.uniform(0.45, 0.60);  // plain cardboard, no tape, no label
  // Overhang per side (x-, x+, y-, y+) and the edges' curl: up over a strip, or down over the overhang.
  double overhang[4], strip[4], curl[4];
  for (int side = 0; side < 4; ++side) {
    overhang[side] = rng.uniform(0.0, 0.02);
    const bool curled = rng.chance(0.3);
    const bool up = rng.chance(0.6) || overhang[side] < 0.005;
    strip[side] = curled ? (up ? rng.uniform(0.02, 0.05) : overhang[side]) : 0.0;
    curl[side] = curled ? (up ? 1.0 : -1.0) * rng.uniform(0.001, 0.004) : 0.0;
  }
  const double x0 = -0.5 * scene.pallet_long_m - overhang[0], x1 = 0.5 * scene.pallet_long_m + overhang[1];
  const double y0 = -0.5 * scene.pallet_short_m - overhang[2], y1 = 0.5 * scene.pallet_short_m + overhang[3];
  const double top_z_m = bottom_z_m + thickness_m;
  auto piece = [&](double ax, double bx, double ay, double by, double dz) {
    if (bx - ax < 1e-4 || by - ay < 1e-4) return;
    SimBox b = cuboid(Eigen::Vector2d(0.5 * (ax + bx), 0.5 * (ay + by)), 0.0, bx - ax, by - ay,
                      bottom_z_m + dz, top_z_m + dz, rho);
    scene.boxes.push_back(b);
  };
  // The flat middle, then the curled strips along the edges.
  piece(x0 + strip[0], x1 - strip[1], y0 + strip[2], y1 - strip[3], 0.0);
  piece(x0, x0 + strip[0], y0, y1, curl[0]);
  piece(x1 - strip[1], x1, y0, y1, curl[1]);
  piece(x0 + strip[0], x1 - strip[1], y0, y0 + strip[2], curl[2]);
  piece(x0 + strip[0], x1 - strip[1], y1 - strip[3], y1, curl[3]);
  return top_z_m;
}

}  // namespace palletd::sim::detail
