// A simulated full block layer that the cell tests share (picking, confidence).
#pragma once

#include <cstdint>

#include <catch2/catch.hpp>

#include "palletd/sim/sim.hpp"

namespace palletd::testing {

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

}  // namespace palletd::testing
