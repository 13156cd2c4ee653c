// palletd sim: a depalletizing cell around the pallet (cabinet, posts, conveyor, second stack)
// and the region of interest suggested for it (docs/simulator.md, "Scene families").
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "raycast.hpp"
#include "sim_internal.hpp"

namespace palletd::sim::detail {
namespace {

/// One side of the pallet: outward direction, half extents of the pallet along it and across it.
struct Side {
  Eigen::Vector2d out;        ///< unit, outward
  Eigen::Vector2d along;      ///< unit, along the side
  double half_out_m = 0.0;    ///< pallet half extent along `out`
  double half_along_m = 0.0;  ///< pallet half extent along `along`
};

Side side_of(const Scene& scene, int index) {
  const double hl = 0.5 * scene.pallet_long_m, hs = 0.5 * scene.pallet_short_m;
  const double sign = index % 2 == 0 ? 1.0 : -1.0;
  if (index < 2) return {Eigen::Vector2d(sign, 0.0), Eigen::Vector2d(0.0, 1.0), hl, hs};
  return {Eigen::Vector2d(0.0, sign), Eigen::Vector2d(1.0, 0.0), hs, hl};
}

/// A cuboid `along_m` long along the side and `out_m` deep, its centre `dist_m` out from the
/// pallet's centre line and `shift_m` along the side.
SimBox part(const Side& side, double dist_m, double shift_m, double along_m, double out_m, double bottom_z_m,
            double top_z_m, double reflectance) {
  return cuboid(side.out * dist_m + side.along * shift_m, std::atan2(side.along.y(), side.along.x()), along_m,
                out_m, bottom_z_m, top_z_m, reflectance);
}

void push_part(Scene& scene, const SimBox& b) {
  scene.surroundings.push_back(scene.boxes.size());
  scene.boxes.push_back(b);
}

/// A machine cabinet or robot base 0.2-0.45 m from the pallet, its top 0.1-0.5 m above the load.
void add_cabinet(Scene& scene, const Side& side, double load_top_z_m, Rng& rng) {
  const double depth_m = rng.uniform(0.4, 0.8);
  const double width_m = rng.uniform(0.6, 1.2);
  const double gap_m = rng.uniform(0.2, 0.45);
  const double shift_m = rng.uniform(-0.5, 0.5) * side.half_along_m;
  const double top_m = load_top_z_m + rng.uniform(0.1, 0.5);
  const double rho = rng.uniform(0.2, 0.7);  // painted sheet metal
  push_part(scene,
            part(side, side.half_out_m + gap_m + 0.5 * depth_m, shift_m, width_m, depth_m, 0.0, top_m, rho));
}

/// Two fence posts (square tubes, 1.3-2.0 m) 0.7-1.0 m from the pallet.
void add_posts(Scene& scene, const Side& side, Rng& rng) {
  const double dist_m = side.half_out_m + rng.uniform(0.7, 1.0);
  const double size_m = rng.uniform(0.06, 0.10);
  const double rho = rng.uniform(0.3, 0.6);
  for (double sign : {-1.0, 1.0}) {
    const double shift_m = sign * (side.half_along_m + rng.uniform(0.0, 0.3));
    const double height_m = rng.uniform(1.3, 2.0);
    push_part(scene, part(side, dist_m, shift_m, size_m, size_m, 0.0, height_m, rho));
  }
}

/// A roller conveyor along the side: frame, two side rails and rollers (50 mm, 120 mm pitch)
/// whose tops form a surface at about the pallet's height.
void add_conveyor(Scene& scene, const Side& side, Rng& rng) {
  const double length_m = rng.uniform(1.5, 3.0);
  const double width_m = rng.uniform(0.6, 0.8);
  const double dist_m = side.half_out_m + rng.uniform(0.15, 0.4) + 0.5 * width_m;
  const double shift_m = rng.uniform(-0.3, 0.3);
  const double surface_z_m = kPalletHeight_m + rng.uniform(-0.03, 0.03);
  const double rho = rng.uniform(0.2, 0.5);
  push_part(scene, part(side, dist_m, shift_m, length_m, width_m - 0.08, 0.0, surface_z_m - 0.06, rho));
  for (double sign : {-1.0, 1.0})
    push_part(scene, part(side, dist_m + sign * (0.5 * width_m - 0.02), shift_m, length_m, 0.04, 0.0,
                          surface_z_m + 0.01, rho));
  const double pitch_m = 0.12;
  const int rollers = static_cast<int>(std::floor(length_m / pitch_m));
  for (int i = 0; i < rollers; ++i) {
    const double at_m = shift_m - 0.5 * length_m + (i + 0.5) * pitch_m;
    SimBox roller = part(side, dist_m, at_m, 0.05, width_m - 0.08, surface_z_m - 0.05, surface_z_m, 0.6);
    push_part(scene, roller);
  }
}

/// Another pallet with one or two block layers of `format` (no truth), 0.3-0.6 m from the pallet.
void add_second_stack(Scene& scene, const Side& side, const CellInput& input, Rng& rng) {
  const double dist_m = 2.0 * side.half_out_m + rng.uniform(0.3, 0.6);
  const Eigen::Vector2d center = side.out * dist_m + side.along * rng.uniform(-0.2, 0.2);
  const std::size_t first = scene.boxes.size();
  add_pallet(scene, center, input.solid_deck);
  for (std::size_t i = first; i < scene.boxes.size(); ++i) scene.surroundings.push_back(i);
  const BoxFormatSpec& f = input.stack_format;
  const int nx = static_cast<int>(std::floor(scene.pallet_long_m / (f.long_m + 0.005)));
  const int ny = static_cast<int>(std::floor(scene.pallet_short_m / (f.short_m + 0.005)));
  const int layers = std::clamp(rng.integer(1, 2), 1, std::max(1, input.max_stack_layers));
  const double base_z_m = scene.pallet == PalletKind::kNone ? 0.0 : kPalletHeight_m;
  for (int layer = 0; layer < layers; ++layer)
    for (int i = 0; i < nx; ++i)
      for (int j = 0; j < ny; ++j) {
        SimBox b;
        b.center = center + Eigen::Vector2d((i - 0.5 * (nx - 1)) * (f.long_m + 0.005),
                                            (j - 0.5 * (ny - 1)) * (f.short_m + 0.005));
        b.long_m = f.long_m;
        b.short_m = f.short_m;
        b.bottom_z_m = base_z_m + layer * f.height_m;
        b.top_z_m = b.bottom_z_m + f.height_m;
        b.bulge_m = rng.uniform(-0.003, 0.003);
        b.bevel_m = 0.003;
        b.reflectance = rng.uniform(0.4, 0.6);
        push_part(scene, b);
      }
}

}  // namespace

void add_surroundings(Scene& scene, const CellInput& input, Rng& rng) {
  // Each part gets its own side of the pallet, in a random order.
  int sides[4] = {0, 1, 2, 3};
  for (int i = 3; i > 0; --i) std::swap(sides[i], sides[rng.index(static_cast<std::size_t>(i + 1))]);
  add_cabinet(scene, side_of(scene, sides[0]), input.load_top_z_m, rng);
  if (rng.chance(0.7)) add_conveyor(scene, side_of(scene, sides[1]), rng);
  if (rng.chance(0.5)) add_second_stack(scene, side_of(scene, sides[2]), input, rng);
  if (rng.chance(0.6)) add_posts(scene, side_of(scene, sides[3]), rng);
}

void add_pallet_stops(Scene& scene, double load_top_z_m, Rng& rng) {
  int sides[4] = {0, 1, 2, 3};
  for (int i = 3; i > 0; --i) std::swap(sides[i], sides[rng.index(static_cast<std::size_t>(i + 1))]);
  const int count = rng.integer(1, 4);
  for (int k = 0; k < count; ++k) {
    const Side side = side_of(scene, sides[k]);
    const double size_m = rng.uniform(0.06, 0.10);
    const double gap_m = rng.uniform(0.02, 0.06);
    const double shift_m = rng.uniform(-0.8, 0.8) * (side.half_along_m - 0.5 * size_m);
    const double top_m = load_top_z_m + rng.uniform(0.05, 0.4);
    scene.stops.push_back(scene.boxes.size());
    scene.boxes.push_back(part(side, side.half_out_m + gap_m + 0.5 * size_m, shift_m, size_m, size_m, 0.0, top_m,
                               rng.uniform(0.3, 0.6)));
  }
}

bool surroundings_hide(const Scene& scene, const std::vector<Eigen::Vector3d>& points_world) {
  const Eigen::Vector3d camera = scene.T_world_camera.translation();
  for (std::size_t idx : scene.surroundings) {
    const PreparedBox b = prepare(scene.boxes[idx]);
    for (const Eigen::Vector3d& p : points_world)
      if (blocks_segment(b, p, camera - p, 1e-6)) return true;
  }
  return false;
}

}  // namespace palletd::sim::detail

namespace palletd::sim {

std::string roi_yaml(const Scene& scene) {
  if (!scene.has_roi) return {};
  const Eigen::Vector3d& lo = scene.roi_min_m;
  const Eigen::Vector3d& hi = scene.roi_max_m;
  char text[600];
  const int n =
      std::snprintf(text, sizeof text,
                    "# Suggested region of interest for this simulated cell (world frame = base frame).\n"
                    "detection:\n"
                    "  roi:\n"
                    "    frame: base\n"
                    "    min_m: [%.3f, %.3f, %.3f]\n"
                    "    max_m: [%.3f, %.3f, %.3f]\n",
                    lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z());
  // The pallet's top deck, as an integrator measures it at commissioning.
  if (scene.pallet != PalletKind::kNone && n > 0 && static_cast<std::size_t>(n) < sizeof text) {
    std::snprintf(text + n, sizeof text - static_cast<std::size_t>(n), "pallet:\n  top_z_m: %.3f\n",
                  detail::kPalletHeight_m);
  }
  return text;
}

Eigen::Isometry3d camera_looking_at(const Eigen::Vector3d& position, const Eigen::Vector3d& target) {
  const Eigen::Vector3d f = (target - position).normalized();
  const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - f.x() * f).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = f.cross(x);
  T.linear().col(2) = f;
  T.translation() = position;
  return T;
}

}  // namespace palletd::sim
