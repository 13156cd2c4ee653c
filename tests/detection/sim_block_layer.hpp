// Simulated layers that the cell tests share (picking, confidence, unknown cartons, fattened edges).
#pragma once

#include <cstdint>
#include <vector>

#include <catch2/catch.hpp>

#include "palletd/core/geometry.hpp"
#include "palletd/sim/sim.hpp"

namespace palletd::testing {

/// The top of the simulator's pallets above the floor (world = base frame) [m].
inline constexpr double kPalletTop_m = 0.144;

/// A full block layer of 400x300 cartons on a EUR pallet, seen by a helios2 from 1.6-2.0 m
/// (base = world): seams and outline seen well.
inline sim::Scene block_layer_scene(std::uint64_t seed) {
  const sim::SensorProfile profile = *sim::profile_by_name("helios2");
  sim::ScenarioOptions options;
  options.pattern = sim::PatternFamily::kBlock;
  options.formats = {*sim::parse_format("400x300x250")};
  options.lower_layers_min = options.lower_layers_max = 1;
  options.height_min_m = 1.6;
  options.height_max_m = 2.0;
  options.tilt_max_deg = 8.0;
  options.gap_max_m = 0.008;
  Expected<sim::Scene> scene = sim::make_scene(options, profile, seed);
  REQUIRE(scene);
  return *scene;
}

/// A layer of one format in `pattern`, one level below it, seen from 1.6-1.9 m with at most 5 deg
/// of tilt and gaps up to gap_max_m.
inline sim::ScenarioOptions layer_options(sim::PatternFamily pattern, const char* format,
                                          double gap_max_m = 0.006) {
  sim::ScenarioOptions options;
  options.pattern = pattern;
  options.formats = {*sim::parse_format(format)};
  options.lower_layers_min = options.lower_layers_max = 1;
  options.height_min_m = 1.6;
  options.height_max_m = 1.9;
  options.tilt_max_deg = 5.0;
  options.gap_max_m = gap_max_m;
  return options;
}

/// layer_options() seen by `profile`.
inline sim::SimulatedFrame render_layer(sim::PatternFamily pattern, const char* format, const char* profile,
                                        std::uint64_t seed, double gap_max_m = 0.006) {
  const sim::SensorProfile p = *sim::profile_by_name(profile);
  Expected<sim::Scene> scene = sim::make_scene(layer_options(pattern, format, gap_max_m), p, seed);
  REQUIRE(scene);
  return sim::render(*scene, p, seed);
}

/// The formats of a simulated frame's recipe, each of height `height_m` (0: not given).
inline std::vector<BoxFormat> formats_of(const sim::SimulatedFrame& f, double height_m = 0.0) {
  std::vector<BoxFormat> out;
  for (const auto& r : f.scene.recipe) out.push_back(BoxFormat{r.long_m, r.short_m, r.name, height_m});
  return out;
}

}  // namespace palletd::testing
