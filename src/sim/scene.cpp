// palletd sim: scene building (pallet, lower layers, top layer with real-box effects, camera).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "sim_internal.hpp"

namespace palletd::sim {
namespace {

using detail::kPi;
using detail::PlacedBox;
using detail::Rng;

double default_height_m(int long_mm, int short_mm) {
  if (long_mm >= 600) return 0.25;
  if (long_mm >= 400) return 0.22;
  if (long_mm >= 300 && short_mm >= 220) return 0.20;
  if (long_mm >= 300) return 0.18;
  return 0.12;
}

BoxFormatSpec format_mm(int long_mm, int short_mm) {
  return *parse_format(std::to_string(long_mm) + "x" + std::to_string(short_mm));
}

std::vector<BoxFormatSpec> default_formats(PatternFamily pattern) {
  switch (pattern) {
    case PatternFamily::kBlock: return {format_mm(600, 400)};
    case PatternFamily::kInterlock: return {format_mm(400, 300)};
    case PatternFamily::kBrick: return {format_mm(300, 200)};
    case PatternFamily::kPinwheel:
    case PatternFamily::kChimney: return {format_mm(315, 232)};
    case PatternFamily::kMixed: return {format_mm(600, 400), format_mm(400, 300)};
  }
  return {format_mm(600, 400)};
}

bool inside_area(const SimBox& b, double half_long, double half_short) {
  for (const auto& p : detail::footprint_corners(b.center, b.yaw_rad, b.long_m, b.short_m))
    if (std::abs(p.x()) > half_long + 1e-9 || std::abs(p.y()) > half_short + 1e-9) return false;
  return true;
}

void decorate(SimBox& box, const ScenarioOptions& o, Rng& rng) {
  box.bulge_m = rng.uniform(-o.bulge_max_m, o.bulge_max_m);
  box.bevel_m = o.bevel_m * rng.uniform(0.7, 1.3);
  box.reflectance = rng.uniform(0.40, 0.60);  // brown cardboard
  if (rng.chance(o.tape_probability)) {
    const double rho = rng.chance(0.6) ? rng.uniform(0.25, 0.35) : rng.uniform(0.65, 0.75);
    box.patches.push_back({Eigen::Vector2d::Zero(), Eigen::Vector2d(0.5 * box.long_m, 0.024), rho});
  }
  if (rng.chance(o.label_probability)) {
    const Eigen::Vector2d half(0.05, 0.035);
    const double mx = std::max(0.0, 0.5 * box.long_m - half.x() - 0.02);
    const double my = std::max(0.0, 0.5 * box.short_m - half.y() - 0.02);
    // One draw per statement (argument evaluation order is unspecified); the order is the one
    // gcc used when the seeded sets were made: y, then x, then the reflectance.
    const double label_y_m = rng.uniform(-my, my);
    const double label_x_m = rng.uniform(-mx, mx);
    const double label_rho = rng.uniform(0.8, 0.9);
    box.patches.push_back({Eigen::Vector2d(label_x_m, label_y_m), half, label_rho});
  }
  // Drawn last and only when asked for, so that scenes without it keep their random numbers.
  if (o.corner_radius_max_m > 0.0) box.corner_radius_m = rng.uniform(o.corner_radius_min_m, o.corner_radius_max_m);
}

/// Turns a nominal pattern into real boxes: gaps, whole-layer offset, size tolerance, jitter.
/// Boxes never overlap and stay inside the area (a perturbation is halved until it fits).
std::vector<SimBox> build_layer(std::vector<PlacedBox> pattern, const std::vector<BoxFormatSpec>& formats,
                                double base_z, double layer_height, const Eigen::Vector2d& area_half_m,
                                const ScenarioOptions& o, bool mirror, Rng& rng) {
  const double hl = area_half_m.x();
  const double hs = area_half_m.y();
  auto extent = [&](const PlacedBox& p) {
    const BoxFormatSpec& f = formats[static_cast<std::size_t>(p.format)];
    const bool along_x = std::abs(std::cos(p.yaw_rad)) > 0.5;
    return along_x ? Eigen::Vector2d(0.5 * f.long_m, 0.5 * f.short_m) : Eigen::Vector2d(0.5 * f.short_m, 0.5 * f.long_m);
  };
  if (mirror)
    for (PlacedBox& p : pattern) p.center.x() = -p.center.x();
  // Spread the layout so neighbours get a gap of about `gap`, as far as the pallet allows.
  const double gap = rng.uniform(0.0, o.gap_max_m);
  for (int axis = 0; axis < 2; ++axis) {
    const double half_area = axis == 0 ? hl : hs;
    double pitch = 1e30, k_max = 1e30;
    for (const PlacedBox& p : pattern) {
      const double e = extent(p)[axis];
      pitch = std::min(pitch, 2.0 * e);
      if (std::abs(p.center[axis]) > 1e-9) k_max = std::min(k_max, (half_area - e) / std::abs(p.center[axis]));
    }
    const double k = std::max(1.0, std::min(1.0 + gap / pitch, k_max));
    for (PlacedBox& p : pattern) p.center[axis] *= k;
  }
  // Whole-layer offset within the slack left on the pallet.
  Eigen::Vector2d slack(hl, hs);
  for (const PlacedBox& p : pattern) slack = slack.cwiseMin(Eigen::Vector2d(hl, hs) - (p.center.cwiseAbs() + extent(p)));
  Eigen::Vector2d offset;
  for (int axis = 0; axis < 2; ++axis) {
    const double lim = std::max(0.0, std::min(o.layer_offset_max_m, slack[axis]));
    offset[axis] = rng.uniform(-lim, lim);
  }
  std::vector<SimBox> nominal;
  for (const PlacedBox& p : pattern) {
    const BoxFormatSpec& f = formats[static_cast<std::size_t>(p.format)];
    SimBox b;
    b.center = p.center + offset;
    b.yaw_rad = p.yaw_rad;
    b.long_m = f.long_m;
    b.short_m = f.short_m;
    b.bottom_z_m = base_z;
    b.top_z_m = base_z + layer_height;
    b.format = f.name;
    b.format_index = p.format;
    nominal.push_back(b);
  }
  std::vector<SimBox> placed;
  for (std::size_t i = 0; i < nominal.size(); ++i) {
    const double dl = rng.uniform(-o.size_tolerance_m, o.size_tolerance_m);
    const double ds = rng.uniform(-o.size_tolerance_m, o.size_tolerance_m);
    const double dc_y_m = rng.uniform(-o.jitter_m, o.jitter_m);  // y before x: see decorate()
    const double dc_x_m = rng.uniform(-o.jitter_m, o.jitter_m);
    const Eigen::Vector2d dc(dc_x_m, dc_y_m);
    const double dyaw = rng.uniform(-o.jitter_deg, o.jitter_deg) * kPi / 180.0;
    SimBox box = nominal[i];
    for (int attempt = 0; attempt <= 6; ++attempt) {
      const double scale = attempt == 6 ? 0.0 : std::pow(0.5, attempt);
      box = nominal[i];
      box.long_m += attempt == 6 ? std::min(dl, 0.0) : scale * dl;
      box.short_m += attempt == 6 ? std::min(ds, 0.0) : scale * ds;
      box.center += scale * dc;
      box.yaw_rad += scale * dyaw;
      bool ok = attempt == 6 || inside_area(box, hl, hs);
      for (std::size_t j = 0; ok && j < placed.size(); ++j) ok = !detail::footprints_overlap(box, placed[j]);
      for (std::size_t j = i + 1; ok && j < nominal.size(); ++j) ok = !detail::footprints_overlap(box, nominal[j]);
      if (ok) break;
    }
    box.top_z_m += rng.uniform(-o.height_tolerance_m, o.height_tolerance_m);
    decorate(box, o, rng);
    placed.push_back(box);
  }
  return placed;
}

Eigen::Isometry3d camera_pose(const Eigen::Vector3d& target, double height, double tilt, double azimuth,
                              double roll) {
  const Eigen::Vector3d f(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth), -std::cos(tilt));
  const Eigen::Vector3d ref(std::cos(roll), std::sin(roll), 0.0);
  const Eigen::Vector3d x = (ref - ref.dot(f) * f).normalized();
  const Eigen::Vector3d y = f.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = x;
  T.linear().col(1) = y;
  T.linear().col(2) = f;
  T.translation() = target - f * (height / std::cos(tilt));
  return T;
}

/// True when every point lies inside the image with the margin (a share of the image size).
bool points_in_view(const Scene& scene, const std::vector<Eigen::Vector3d>& points, const Intrinsics& k,
                    double margin) {
  const Eigen::Isometry3d T_camera_world = scene.T_world_camera.inverse();
  const double mu = margin * k.width, mv = margin * k.height;
  for (const Eigen::Vector3d& p : points) {
    Eigen::Vector2d px;
    if (!project(k, T_camera_world * p, px)) return false;
    if (px.x() < mu || px.y() < mv || px.x() > k.width - 1 - mu || px.y() > k.height - 1 - mv) return false;
  }
  return true;
}

/// The points the camera must see: the top-face corners of the top layer's boxes, or, with no
/// boxes on top, the corners of the pallet's top plane (deck or slip sheet).
std::vector<Eigen::Vector3d> focus_points(const Scene& scene) {
  std::vector<Eigen::Vector3d> points;
  for (std::size_t idx : scene.top_layer) {
    const SimBox& b = scene.boxes[idx];
    for (const auto& c : detail::footprint_corners(b.center, b.yaw_rad, b.long_m, b.short_m))
      points.emplace_back(c.x(), c.y(), b.top_z_m);
  }
  if (points.empty())
    for (const auto& c : detail::footprint_corners(Eigen::Vector2d::Zero(), 0.0, scene.pallet_long_m, scene.pallet_short_m))
      points.emplace_back(c.x(), c.y(), scene.top_z_m);
  return points;
}

/// The middle of the cabinet's top edge nearest the pallet (cell scenes), world [m].
bool cabinet_edge(const Scene& scene, Eigen::Vector3d& point) {
  if (scene.surroundings.empty()) return false;
  const SimBox& b = scene.boxes[scene.surroundings.front()];
  const Eigen::Vector2d inward = -b.center.normalized();
  const Eigen::Vector2d across(-std::sin(b.yaw_rad), std::cos(b.yaw_rad));  // the short side's direction
  const Eigen::Vector2d edge = b.center + 0.5 * b.short_m * (across.dot(inward) >= 0.0 ? across : -across);
  point = Eigen::Vector3d(edge.x(), edge.y(), b.top_z_m);
  return true;
}

/// Whether a drawn pose will do: the focus points in view; in a cell also not hidden by its
/// parts, and in the first half of the draws the cabinet's near edge in view too.
bool pose_fits(const Scene& scene, const std::vector<Eigen::Vector3d>& focus, const ScenarioOptions& o,
               const Intrinsics& k, double share) {
  if (!o.keep_layer_in_view) return true;
  if (!points_in_view(scene, focus, k, o.view_margin)) return false;
  if (scene.surroundings.empty()) return true;
  if (detail::surroundings_hide(scene, focus)) return false;
  Eigen::Vector3d edge;
  return share >= 0.5 || !cabinet_edge(scene, edge) || points_in_view(scene, {edge}, k, 0.0);
}

void place_camera(Scene& scene, const ScenarioOptions& o, const SensorProfile& profile, Rng& rng) {
  const std::vector<Eigen::Vector3d> focus = focus_points(scene);
  Eigen::Vector2d lo(1e30, 1e30), hi(-1e30, -1e30);
  for (const Eigen::Vector3d& p : focus) {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  // A cell's camera is calibrated and tilted by cell_tilt_min..max; elsewhere 0..tilt_max.
  const bool in_cell = !scene.surroundings.empty();
  const double tilt_hi_deg = in_cell ? std::min(o.tilt_max_deg, o.cell_tilt_max_deg) : o.tilt_max_deg;
  const double tilt_lo_deg = in_cell ? std::min(o.cell_tilt_min_deg, tilt_hi_deg) : 0.0;
  const double tilt_lo = tilt_lo_deg * kPi / 180.0;
  const double tilt_max = tilt_hi_deg * kPi / 180.0 - tilt_lo;
  constexpr int kAttempts = 200;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    // Later attempts look from higher up and less tilted, which always fits in the end.
    const double share = static_cast<double>(attempt) / kAttempts;
    const double h_lo = o.height_min_m + share * (o.height_max_m - o.height_min_m);
    const double height = rng.uniform(h_lo, o.height_max_m);
    const double tilt = tilt_lo + rng.uniform(0.0, tilt_max * (1.0 - share));
    const double azimuth = rng.uniform(0.0, 2.0 * kPi);
    const double roll = rng.uniform(0.0, 2.0 * kPi);
    const double target_dy_m = rng.uniform(-0.03, 0.03);  // y before x: see decorate()
    const double target_dx_m = rng.uniform(-0.03, 0.03);
    const Eigen::Vector3d target(mid.x() + target_dx_m, mid.y() + target_dy_m, scene.top_z_m);
    scene.T_world_camera = camera_pose(target, height, tilt, azimuth, roll);
    if (pose_fits(scene, focus, o, profile.intrinsics, share)) return;
  }
  scene.T_world_camera = camera_pose(Eigen::Vector3d(mid.x(), mid.y(), scene.top_z_m), o.height_max_m, tilt_lo, 0.0, 0.0);
}

/// The layer as built: formats and layout grown by the oversize (names stay nominal), and the
/// area the layer may cover (the pallet, grown likewise: oversized boxes overhang it).
struct BuiltLayer {
  std::vector<BoxFormatSpec> formats;
  std::vector<PlacedBox> pattern;
  Eigen::Vector2d half_area;
};

BuiltLayer build_sizes(const std::vector<PlacedBox>& pattern, const std::vector<BoxFormatSpec>& formats,
                       const Scene& scene, const ScenarioOptions& o, Rng& rng) {
  BuiltLayer built{formats, pattern, Eigen::Vector2d(0.5 * scene.pallet_long_m, 0.5 * scene.pallet_short_m)};
  if (o.oversize_max <= 0.0) return built;  // no draw: scenes without oversize keep their numbers
  const double scale = 1.0 + rng.uniform(0.2 * o.oversize_max, o.oversize_max);
  for (BoxFormatSpec& f : built.formats) {
    f.long_m *= scale;
    f.short_m *= scale;
  }
  for (PlacedBox& p : built.pattern) p.center *= scale;
  built.half_area *= scale;
  return built;
}

/// Puts the boxes of the top layer that remain into the scene (fill and removal mode, or one to
/// three on a stepped pallet); returns what remains, e.g. "8 of 12 boxes (rows)".
std::string place_top_layer(Scene& scene, const std::vector<SimBox>& top, const ScenarioOptions& o, Rng& rng) {
  const std::size_t n = top.size();
  std::size_t keep = 0;
  if (o.scene == SceneFamily::kStepped) {
    const int lo = std::max(1, o.stepped_min);
    keep = std::clamp<std::size_t>(static_cast<std::size_t>(rng.integer(lo, std::max(lo, o.stepped_max))), 1, n);
  } else {
    const double fill = std::clamp(o.fill, 0.0, 1.0);
    keep = std::clamp<std::size_t>(static_cast<std::size_t>(std::lround(fill * static_cast<double>(n))), 1, n);
  }
  std::vector<bool> removed(n, false);
  if (keep < n) {
    const std::vector<std::size_t> order = detail::removal_order(top, o.removal, rng);
    for (std::size_t i = 0; i < n - keep; ++i) removed[order[i]] = true;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (removed[i]) continue;
    scene.top_layer.push_back(scene.boxes.size());
    scene.boxes.push_back(top[i]);
  }
  char text[80];
  std::snprintf(text, sizeof text, "%zu of %zu boxes (%s)", keep, n, keep < n ? to_string(o.removal).c_str() : "full");
  return text;
}

/// The cell around the pallet (own random stream) and the region of interest suggested for it:
/// the pallet grown by 0.1 m, from 0.05 m below the deck's top to 0.3 m above the full load.
void add_cell(Scene& scene, const BoxFormatSpec& format, double load_top_m, int stack_layers,
              const ScenarioOptions& o, std::uint64_t seed) {
  Rng cell_rng(seed, 0xCE11);
  detail::CellInput input;
  input.load_top_z_m = load_top_m;
  input.max_stack_layers = stack_layers;
  input.stack_format = format;
  input.solid_deck = o.solid_deck;
  detail::add_surroundings(scene, input, cell_rng);
  const double deck_m = scene.pallet == PalletKind::kNone ? 0.0 : detail::kPalletHeight_m;
  scene.has_roi = true;
  scene.roi_min_m = Eigen::Vector3d(-0.5 * scene.pallet_long_m - 0.1, -0.5 * scene.pallet_short_m - 0.1, deck_m - 0.05);
  scene.roi_max_m = Eigen::Vector3d(0.5 * scene.pallet_long_m + 0.1, 0.5 * scene.pallet_short_m + 0.1, load_top_m + 0.3);
}

}  // namespace

Expected<BoxFormatSpec> parse_format(const std::string& text) {
  int l = 0, s = 0, h = 0;
  char x1 = 0, x2 = 0;
  std::istringstream in(text);
  in >> l >> x1 >> s;
  if (!in || (x1 != 'x' && x1 != 'X') || l <= 0 || s <= 0)
    return Error{"box format '" + text + "' is not LONGxSHORT[xHEIGHT] in millimetres"};
  if (in >> x2) {
    if ((x2 != 'x' && x2 != 'X') || !(in >> h) || h <= 0)
      return Error{"box format '" + text + "' is not LONGxSHORT[xHEIGHT] in millimetres"};
  }
  if (s > l) std::swap(l, s);
  BoxFormatSpec f;
  f.name = std::to_string(l) + "x" + std::to_string(s);
  f.long_m = l / 1000.0;
  f.short_m = s / 1000.0;
  f.height_m = h > 0 ? h / 1000.0 : default_height_m(l, s);
  return f;
}

Expected<Scene> make_scene(const ScenarioOptions& o, const SensorProfile& profile, std::uint64_t seed) {
  Rng rng(seed, 0x5CE4E);
  Scene scene;
  scene.pallet = o.pallet;
  scene.family = o.scene;
  scene.pallet_long_m = 1.2;
  scene.pallet_short_m = o.pallet == PalletKind::kIndustrial1200x1000 ? 1.0 : 0.8;
  scene.floor_reflectance = rng.uniform(0.15, 0.35);
  std::vector<BoxFormatSpec> formats = o.formats.empty() ? default_formats(o.pattern) : o.formats;
  if (o.pattern == PatternFamily::kMixed && formats.size() < 2) {
    const BoxFormatSpec second = formats[0].long_m >= 0.5 ? format_mm(400, 300) : format_mm(600, 400);
    formats.push_back(second);
  }
  if (o.pattern != PatternFamily::kMixed) formats.resize(1);
  const double layer_height = formats[0].height_m;  // one height per layer: a flat top
  const std::vector<PlacedBox> pattern =
      detail::make_pattern(o.pattern, formats, scene.pallet_long_m, scene.pallet_short_m, rng);
  if (pattern.empty())
    return Error{"no box of format " + formats[0].name + " fits the " + to_string(o.pallet) + " pallet"};

  detail::add_pallet(scene, Eigen::Vector2d::Zero(), o.solid_deck);
  const double base = o.pallet == PalletKind::kNone ? 0.0 : detail::kPalletHeight_m;
  const BuiltLayer built = build_sizes(pattern, formats, scene, o, rng);
  const int drawn_lower = rng.integer(std::max(0, o.lower_layers_min), std::max(o.lower_layers_min, o.lower_layers_max));
  const bool needs_level = o.scene == SceneFamily::kStepped || o.scene == SceneFamily::kSlipSheet;
  const int lower = o.scene == SceneFamily::kEmpty ? 0 : (needs_level ? std::max(drawn_lower, 1) : drawn_lower);
  double z = base;
  for (int layer = 0; layer < lower; ++layer) {
    // Lower layers alternate mirrored, as palletizers interlock them.
    const bool mirror = ((lower - layer) % 2) == 1;
    for (SimBox& b : build_layer(built.pattern, built.formats, z, layer_height, built.half_area, o, mirror, rng))
      scene.boxes.push_back(b);
    z += layer_height;
  }
  std::string load;
  if (o.scene == SceneFamily::kEmpty) {
    scene.top_z_m = base;
    scene.expect = "empty";
    load = "empty pallet";
  } else if (o.scene == SceneFamily::kSlipSheet) {
    // The sheet lies flat on the highest bulges of the level below.
    scene.top_z_m = detail::add_slip_sheet(scene, z + o.bulge_max_m + o.height_tolerance_m + 0.0005, rng);
    scene.expect = "slip_sheet";
    load = "slip sheet";
  } else {
    const std::vector<SimBox> top = build_layer(built.pattern, built.formats, z, layer_height, built.half_area, o, false, rng);
    scene.top_z_m = z + layer_height;
    load = place_top_layer(scene, top, o, rng);
  }
  scene.recipe = formats;
  for (const BoxFormatSpec& f : o.extra_recipe) scene.recipe.push_back(f);
  if (o.cell || o.scene == SceneFamily::kCell) {
    const double load_top_m = std::max(scene.top_z_m, base + (drawn_lower + 1) * layer_height);
    add_cell(scene, built.formats[0], load_top_m, std::max(1, drawn_lower), o, seed);
  }
  if (o.pallet_stops) {
    Rng stop_rng(seed, 0x5709);
    detail::add_pallet_stops(scene, std::max(scene.top_z_m, base + (drawn_lower + 1) * layer_height), stop_rng);
  }
  char text[200];
  std::snprintf(text, sizeof text, "%s %s on %s, %d lower layers, %s%s", to_string(o.pattern).c_str(),
                formats[0].name.c_str(), to_string(o.pallet).c_str(), lower, load.c_str(),
                scene.surroundings.empty() ? "" : ", in a cell");
  scene.description = text;
  place_camera(scene, o, profile, rng);
  return scene;
}

Truth make_truth(const Scene& scene) {
  Truth truth;
  const Eigen::Isometry3d T_camera_world = scene.T_world_camera.inverse();
  const Eigen::Matrix3d R = T_camera_world.linear();
  for (std::size_t idx : scene.top_layer) {
    const SimBox& b = scene.boxes[idx];
    TruthBox t;
    t.center = T_camera_world * Eigen::Vector3d(b.center.x(), b.center.y(), b.top_z_m);
    t.long_axis = R * Eigen::Vector3d(std::cos(b.yaw_rad), std::sin(b.yaw_rad), 0.0);
    t.normal = R * Eigen::Vector3d::UnitZ();
    t.long_m = b.long_m;
    t.short_m = b.short_m;
    t.format = b.format;
    truth.boxes.push_back(t);
  }
  truth.expect = scene.expect;
  truth.layer_plane.normal = R * Eigen::Vector3d::UnitZ();
  truth.layer_plane.d = -truth.layer_plane.normal.dot(T_camera_world * Eigen::Vector3d(0.0, 0.0, scene.top_z_m));
  for (const BoxFormatSpec& f : scene.recipe) {
    truth.recipe.push_back(f.name);
    truth.recipe_mm.push_back({static_cast<int>(std::lround(f.long_m * 1000.0)),
                               static_cast<int>(std::lround(f.short_m * 1000.0))});
  }
  return truth;
}

bool project(const Intrinsics& k, const Eigen::Vector3d& p, Eigen::Vector2d& pixel) {
  if (p.z() <= 1e-9) return false;
  pixel = Eigen::Vector2d(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy);
  return true;
}

std::vector<Eigen::Vector3d> truth_corners(const TruthBox& box) {
  const Eigen::Vector3d u = box.long_axis.normalized();
  const Eigen::Vector3d v = box.normal.cross(u).normalized();
  const Eigen::Vector3d hu = 0.5 * box.long_m * u;
  const Eigen::Vector3d hv = 0.5 * box.short_m * v;
  return {box.center - hu - hv, box.center + hu - hv, box.center + hu + hv, box.center - hu + hv};
}

}  // namespace palletd::sim
