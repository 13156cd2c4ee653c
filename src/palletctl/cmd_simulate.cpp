// palletctl simulate: render simulated frames (frame format + truth) into a folder.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "palletd/frames/frame_io.hpp"
#include "palletd/sim/sim.hpp"

namespace palletd {
namespace {

struct SimulateArgs {
  std::string out;
  int count = 1;
  std::vector<std::string> patterns{"block"};
  std::vector<std::string> profiles{"o3d303"};
  std::string pallet = "eur";
  std::vector<std::string> formats;
  std::vector<std::string> extra_formats;
  std::string fill = "1.0";
  std::vector<std::string> removals{"rows"};
  double tilt_max_deg = 30.0;
  double height_min_m = 1.2, height_max_m = 3.0;
  int lower_min = 1, lower_max = 2;
  double gap_max_mm = 15.0;
  double noise_scale = 1.0;
  bool no_noise = false;
  bool partial_view = false;
  std::vector<std::string> scenes{"isolated"};
  bool cell = false;
  bool pallet_stops = false;
  double oversize_max = 0.0;
  std::string corner_radius_mm = "0";
  double bevel_mm = 3.0;
  int stepped_max = 3;
  bool solid_deck = false;
  std::uint64_t seed = 1;
  std::string name;
  bool preview = false;
};

template <typename T>
bool take(Expected<T> value, T& out) {
  if (!value) {
    spdlog::error("simulate: {}", value.error());
    return false;
  }
  out = std::move(*value);
  return true;
}

/// "X" or "LO:HI" -> [lo, hi]; false when it is neither.
bool parse_range(const std::string& text, double& lo, double& hi) {
  const auto colon = text.find(':');
  try {
    lo = std::stod(text.substr(0, colon));
    hi = colon == std::string::npos ? lo : std::stod(text.substr(colon + 1));
  } catch (const std::exception&) {
    return false;
  }
  return lo <= hi;
}

/// The options of issue 19: scene families, cell, real cartons, pallet deck.
bool apply_cell_options(const SimulateArgs& a, sim::SetOptions& set) {
  sim::ScenarioOptions& o = set.scenario;
  for (const std::string& name : a.scenes) {
    if (name == "all") {
      set.scenes = {sim::SceneFamily::kIsolated, sim::SceneFamily::kCell, sim::SceneFamily::kStepped,
                    sim::SceneFamily::kEmpty, sim::SceneFamily::kSlipSheet};
      break;
    }
    sim::SceneFamily family{};
    if (!take(sim::parse_scene(name), family)) return false;
    set.scenes.push_back(family);
  }
  double lo_mm = 0.0, hi_mm = 0.0;
  if (!parse_range(a.corner_radius_mm, lo_mm, hi_mm) || lo_mm < 0.0 || hi_mm > 50.0) {
    spdlog::error("simulate: --corner-radius takes MM or LO:HI in 0..50 mm, not '{}'", a.corner_radius_mm);
    return false;
  }
  o.corner_radius_min_m = lo_mm / 1000.0;
  o.corner_radius_max_m = hi_mm / 1000.0;
  o.cell = a.cell;
  o.pallet_stops = a.pallet_stops;
  o.oversize_max = a.oversize_max;
  o.bevel_m = a.bevel_mm / 1000.0;
  o.stepped_max = a.stepped_max;
  o.solid_deck = a.solid_deck;
  return true;
}

/// STEM.roi.yaml beside a cell scene's frame: the region of interest suggested for it.
bool write_roi(const std::string& stem, const sim::Scene& scene) {
  const std::string text = sim::roi_yaml(scene);
  if (text.empty()) return true;
  std::ofstream out(stem + ".roi.yaml", std::ios::binary);
  out << text;
  if (out.flush()) return true;
  spdlog::error("simulate: cannot write {}.roi.yaml", stem);
  return false;
}

int run_simulate(const SimulateArgs& a) {
  sim::SetOptions set;
  set.count = a.count;
  set.seed = a.seed;
  sim::ScenarioOptions& o = set.scenario;
  if (!take(sim::parse_pallet(a.pallet), o.pallet)) return 2;
  for (const std::string& f : a.formats) {
    sim::BoxFormatSpec spec;
    if (!take(sim::parse_format(f), spec)) return 2;
    o.formats.push_back(spec);
  }
  for (const std::string& f : a.extra_formats) {
    sim::BoxFormatSpec spec;
    if (!take(sim::parse_format(f), spec)) return 2;
    o.extra_recipe.push_back(spec);
  }
  for (const std::string& p : a.patterns) {
    if (p == "all") continue;  // empty list = every family
    sim::PatternFamily family{};
    if (!take(sim::parse_pattern(p), family)) return 2;
    set.patterns.push_back(family);
  }
  for (const std::string& r : a.removals) {
    if (r == "all") continue;
    sim::RemovalMode mode{};
    if (!take(sim::parse_removal(r), mode)) return 2;
    set.removals.push_back(mode);
  }
  for (const std::string& p : a.profiles) {
    if (p == "all") {
      for (const std::string& name : sim::profile_names()) set.profiles.push_back(name);
      continue;
    }
    set.profiles.push_back(p);
  }
  // --fill F or --fill LO:HI
  const auto colon = a.fill.find(':');
  try {
    set.fill_min = std::stod(a.fill.substr(0, colon));
    set.fill_max = colon == std::string::npos ? set.fill_min : std::stod(a.fill.substr(colon + 1));
  } catch (const std::exception&) {
    spdlog::error("simulate: --fill takes F or LO:HI with 0 < F <= 1, not '{}'", a.fill);
    return 2;
  }
  if (set.fill_min <= 0.0 || set.fill_max > 1.0 || set.fill_min > set.fill_max) {
    spdlog::error("simulate: --fill must lie in (0, 1] with LO <= HI");
    return 2;
  }
  o.tilt_max_deg = a.tilt_max_deg;
  o.height_min_m = a.height_min_m;
  o.height_max_m = a.height_max_m;
  o.lower_layers_min = a.lower_min;
  o.lower_layers_max = std::max(a.lower_min, a.lower_max);
  o.gap_max_m = a.gap_max_mm / 1000.0;
  o.keep_layer_in_view = !a.partial_view;
  if (!apply_cell_options(a, set)) return 2;
  set.render.noise_scale = a.noise_scale;
  if (a.no_noise) {
    set.render.noise = false;
    set.render.invalid = false;
    set.render.multipath = false;
  }

  auto frames = sim::generate_set(set);
  if (!frames) {
    spdlog::error("simulate: {}", frames.error());
    return 1;
  }
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (ec) {
    spdlog::error("simulate: cannot create {}: {}", a.out, ec.message());
    return 1;
  }
  for (std::size_t i = 0; i < frames->size(); ++i) {
    const sim::SimulatedFrame& f = (*frames)[i];
    std::string name = f.name;
    if (!a.name.empty()) {
      const std::string number = std::to_string(i);
      name = frames->size() == 1 ? a.name : a.name + (i < 10 ? "_0" : "_") + number;
    }
    const std::string stem = (std::filesystem::path(a.out) / name).string();
    if (Status s = write_frame(stem, f.frame); !s) {
      spdlog::error("simulate: {}", s.error());
      return 1;
    }
    if (Status s = write_truth(stem, f.truth); !s) {
      spdlog::error("simulate: {}", s.error());
      return 1;
    }
    if (!write_roi(stem, f.scene)) return 1;
    if (a.preview) {
      sim::PreviewImage p = sim::render_preview(f);
      const cv::Mat image(p.height, p.width, CV_8UC3, p.bgr.data());
      if (!cv::imwrite(stem + ".preview.png", image)) {
        spdlog::error("simulate: cannot write {}.preview.png", stem);
        return 1;
      }
    }
    std::cout << name << ": " << f.scene.description << ", " << f.truth.boxes.size() << " boxes";
    if (f.truth.expect != "boxes") std::cout << ", expect " << f.truth.expect;
    std::cout << "\n";
  }
  return 0;
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand("simulate", "Render simulated depth frames of pallet layers with ground truth");
  cmd->add_option("--out", args->out, "output folder (created when missing)")->required();
  cmd->add_option(
         "-n,--count", args->count,
         "number of frames; every combination of the patterns, profiles and scenes listed comes once "
         "per round of that many frames, in an order drawn from the seed")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--pattern", args->patterns,
                  "layer pattern(s): block, interlock, brick, pinwheel, chimney, mixed, all")
      ->capture_default_str();
  cmd->add_option("--profile", args->profiles,
                  "sensor profile(s): o3d303, o3d303-small, blaze101, helios2, xtion, d435, all (these six), "
                  "d435-hd (1280x720)")
      ->capture_default_str();
  cmd->add_option("--pallet", args->pallet, "eur (1200x800), ind (1200x1000) or none")->capture_default_str();
  cmd->add_option("--format", args->formats, "box format LONGxSHORT[xHEIGHT] in mm (mixed takes two); default per pattern");
  cmd->add_option("--extra-format", args->extra_formats, "recipe format not present in the layer");
  cmd->add_option("--fill", args->fill, "share of the top layer left, F or LO:HI drawn per frame")->capture_default_str();
  cmd->add_option("--removal", args->removals, "how boxes were removed: rows, columns, corner, random, holes, clusters, all")
      ->capture_default_str();
  cmd->add_option("--tilt-max", args->tilt_max_deg, "maximum camera tilt [deg]")->capture_default_str()->check(CLI::Range(0.0, 45.0));
  cmd->add_option("--height-min", args->height_min_m, "camera height above the top layer, minimum [m]")->capture_default_str();
  cmd->add_option("--height-max", args->height_max_m, "camera height above the top layer, maximum [m]")->capture_default_str();
  cmd->add_option("--lower-min", args->lower_min, "lower layers, minimum")->capture_default_str()->check(CLI::Range(0, 8));
  cmd->add_option("--lower-max", args->lower_max, "lower layers, maximum")->capture_default_str()->check(CLI::Range(0, 8));
  cmd->add_option("--gap-max", args->gap_max_mm, "maximum gap between boxes [mm]")->capture_default_str()->check(CLI::Range(0.0, 50.0));
  cmd->add_option("--noise-scale", args->noise_scale, "multiplies every noise sigma")->capture_default_str()->check(CLI::Range(0.0, 10.0));
  cmd->add_flag("--no-noise", args->no_noise, "no noise, dropouts or multipath (geometry only)");
  cmd->add_flag("--partial-view", args->partial_view, "do not force the top layer into view");
  cmd->add_option("--scene", args->scenes,
                  "scene family(ies): isolated, cell, stepped (1-3 boxes on a full level), empty (bare "
                  "pallet), slip_sheet, all")
      ->capture_default_str();
  cmd->add_flag("--cell", args->cell, "put every scene in a cell (cabinet, posts, conveyor, second stack; writes STEM.roi.yaml)");
  cmd->add_flag("--pallet-stops", args->pallet_stops,
                "posts beside the pallet, higher than the load and inside the region of interest (a gripper keeps clear)");
  cmd->add_option("--oversize-max", args->oversize_max, "boxes built larger than nominal by up to this share (e.g. 0.05)")
      ->capture_default_str()->check(CLI::Range(0.0, 0.1));
  cmd->add_option("--corner-radius", args->corner_radius_mm, "rounded vertical box corners, MM or LO:HI drawn per box [mm]")
      ->capture_default_str();
  cmd->add_option("--bevel", args->bevel_mm, "rounded top edge radius of the boxes (+-30 % per box) [mm]")
      ->capture_default_str()->check(CLI::Range(0.0, 20.0));
  cmd->add_option("--stepped-max", args->stepped_max, "stepped scenes leave 1..N boxes on top")
      ->capture_default_str()->check(CLI::Range(1, 20));
  cmd->add_flag("--solid-deck", args->solid_deck, "the pallet deck as one slab (reproduces sets made before the board deck)");
  cmd->add_option("--seed", args->seed, "random seed; the same seed gives the same bytes")->capture_default_str();
  cmd->add_option("--name", args->name, "frame stem (with _NN appended when -n > 1)");
  cmd->add_flag("--preview", args->preview, "also write STEM.preview.png (depth colour map with truth outlines)");
  cmd->callback([args] { throw CLI::RuntimeError(run_simulate(*args)); });
}

}  // namespace palletd
