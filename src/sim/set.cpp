// palletd sim: names of the enums and in-memory frame sets.
#include <algorithm>
#include <cstdio>

#include "sim_internal.hpp"

namespace palletd::sim {

std::string to_string(PatternFamily pattern) {
  switch (pattern) {
    case PatternFamily::kBlock: return "block";
    case PatternFamily::kInterlock: return "interlock";
    case PatternFamily::kBrick: return "brick";
    case PatternFamily::kPinwheel: return "pinwheel";
    case PatternFamily::kChimney: return "chimney";
    case PatternFamily::kMixed: return "mixed";
  }
  return "block";
}

std::string to_string(RemovalMode mode) {
  switch (mode) {
    case RemovalMode::kRows: return "rows";
    case RemovalMode::kColumns: return "columns";
    case RemovalMode::kCorner: return "corner";
    case RemovalMode::kRandom: return "random";
    case RemovalMode::kHoles: return "holes";
    case RemovalMode::kClusters: return "clusters";
  }
  return "rows";
}

std::string to_string(PalletKind pallet) {
  switch (pallet) {
    case PalletKind::kNone: return "none";
    case PalletKind::kEur1200x800: return "eur";
    case PalletKind::kIndustrial1200x1000: return "ind";
  }
  return "eur";
}

std::string to_string(SceneFamily family) {
  switch (family) {
    case SceneFamily::kIsolated: return "isolated";
    case SceneFamily::kCell: return "cell";
    case SceneFamily::kStepped: return "stepped";
    case SceneFamily::kEmpty: return "empty";
    case SceneFamily::kSlipSheet: return "slip_sheet";
  }
  return "isolated";
}

Expected<SceneFamily> parse_scene(const std::string& text) {
  for (SceneFamily f : {SceneFamily::kIsolated, SceneFamily::kCell, SceneFamily::kStepped, SceneFamily::kEmpty,
                        SceneFamily::kSlipSheet})
    if (to_string(f) == text) return f;
  return Error{"unknown scene '" + text + "' (isolated, cell, stepped, empty, slip_sheet)"};
}

Expected<PatternFamily> parse_pattern(const std::string& text) {
  for (PatternFamily p : {PatternFamily::kBlock, PatternFamily::kInterlock, PatternFamily::kBrick, PatternFamily::kPinwheel,
                          PatternFamily::kChimney, PatternFamily::kMixed})
    if (to_string(p) == text) return p;
  if (text == "column") return PatternFamily::kBlock;
  if (text == "spiral") return PatternFamily::kPinwheel;
  return Error{"unknown pattern '" + text + "' (block, interlock, brick, pinwheel, chimney, mixed)"};
}

Expected<RemovalMode> parse_removal(const std::string& text) {
  for (RemovalMode m : {RemovalMode::kRows, RemovalMode::kColumns, RemovalMode::kCorner, RemovalMode::kRandom,
                        RemovalMode::kHoles, RemovalMode::kClusters})
    if (to_string(m) == text) return m;
  return Error{"unknown removal mode '" + text + "' (rows, columns, corner, random, holes, clusters)"};
}

Expected<PalletKind> parse_pallet(const std::string& text) {
  if (text == "none") return PalletKind::kNone;
  if (text == "eur" || text == "1200x800") return PalletKind::kEur1200x800;
  if (text == "ind" || text == "1200x1000") return PalletKind::kIndustrial1200x1000;
  return Error{"unknown pallet '" + text + "' (eur = 1200x800, ind = 1200x1000, none)"};
}

std::uint64_t frame_seed(std::uint64_t seed, std::uint64_t index) {
  return detail::splitmix64(detail::splitmix64(seed) + index);
}

std::vector<detail::Combination> detail::frame_combinations(std::size_t patterns, std::size_t profiles,
                                                            std::size_t scenes, std::uint64_t seed,
                                                            std::size_t count) {
  const std::size_t round = patterns * profiles * scenes;
  std::vector<Combination> out;
  out.reserve(count);
  std::vector<std::size_t> deck(round);
  for (std::size_t r = 0; round > 0 && out.size() < count; ++r) {
    for (std::size_t c = 0; c < round; ++c) deck[c] = c;
    Rng rng(seed, 0xDEC0 + r);
    for (std::size_t k = round; k > 1; --k) std::swap(deck[k - 1], deck[rng.index(k)]);  // Fisher-Yates
    for (std::size_t k = 0; k < round && out.size() < count; ++k) {
      const std::size_t c = deck[k];
      out.push_back({c % patterns, (c / patterns) % profiles, c / (patterns * profiles)});
    }
  }
  return out;
}

Expected<std::vector<SimulatedFrame>> generate_set(const SetOptions& options) {
  const std::vector<PatternFamily> patterns =
      options.patterns.empty() ? std::vector<PatternFamily>{PatternFamily::kBlock, PatternFamily::kInterlock,
                                                            PatternFamily::kBrick, PatternFamily::kPinwheel,
                                                            PatternFamily::kChimney, PatternFamily::kMixed}
                               : options.patterns;
  const std::vector<std::string> profile_list =
      options.profiles.empty() ? std::vector<std::string>{"o3d303"} : options.profiles;
  const std::vector<RemovalMode> removals =
      options.removals.empty() ? std::vector<RemovalMode>{RemovalMode::kRows, RemovalMode::kColumns, RemovalMode::kCorner,
                                                          RemovalMode::kRandom, RemovalMode::kHoles, RemovalMode::kClusters}
                               : options.removals;
  std::vector<SensorProfile> profiles;
  for (const std::string& name : profile_list) {
    auto p = profile_by_name(name);
    if (!p) return Error{p.error()};
    profiles.push_back(*p);
  }
  const auto count = static_cast<std::size_t>(std::max(0, options.count));
  const std::vector<detail::Combination> shown = detail::frame_combinations(
      patterns.size(), profiles.size(), std::max<std::size_t>(1, options.scenes.size()), options.seed, count);
  std::vector<SimulatedFrame> frames;
  frames.reserve(count);
  for (std::size_t index = 0; index < count; ++index) {
    const int i = static_cast<int>(index);
    const std::uint64_t seed = frame_seed(options.seed, index);
    detail::Rng rng(seed, 0x5E7);
    ScenarioOptions scenario = options.scenario;
    scenario.pattern = patterns[shown[index].pattern];
    scenario.fill = rng.uniform(options.fill_min, options.fill_max);
    scenario.removal = removals[rng.index(removals.size())];
    if (!options.scenes.empty()) scenario.scene = options.scenes[shown[index].scene];
    const SensorProfile& profile = profiles[shown[index].profile];
    auto scene = make_scene(scenario, profile, seed);
    if (!scene) return Error{scene.error()};
    SimulatedFrame frame = render(*scene, profile, seed, options.render);
    // Isolated scenes keep the names they had before there were scene families.
    const std::string family = scenario.scene == SceneFamily::kIsolated ? "" : to_string(scenario.scene) + "_";
    char name[240];
    std::snprintf(name, sizeof name, "%04d_%s%s_%s_%s", i, family.c_str(), to_string(scenario.pattern).c_str(),
                  scene->recipe.front().name.c_str(), profile.name.c_str());
    frame.name = name;
    frame.frame.sequence = index;
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace palletd::sim
