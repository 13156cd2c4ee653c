// palletd_bench_picking [--count N] [--seed S]
// Pickability against the simulator's geometry, for docs/benchmarks.md: frames of isolated,
// cell and stepped scenes with pallet stops (posts beside the pallet, higher than the load,
// inside the region of interest), all patterns, four sensor profiles; three grippers: one the
// box's size, one that takes two boxes end to end, one 100 mm larger than the box.
//
// Safety: no pick reported now (a group's footprint at its TCP) may overlap, in plan, anything
// standing higher than the layer (a stop, a cell part): counted over every frame whose status
// is ok. Recall: the truth's boxes, planned from the true geometry (the scene's boxes, the true
// stops), that can be taken now; in frames whose layout is exact, the share reported pickable.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/picking.hpp"
#include "palletd/results/evaluation.hpp"
#include "palletd/sim/sim.hpp"

using namespace palletd;

namespace {

struct Args {
  int count = 60;
  std::uint64_t seed = 1;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--count")
      a.count = std::atoi(argv[i + 1]);
    else if (k == "--seed")
      a.seed = std::strtoull(argv[i + 1], nullptr, 10);
  }
  return a;
}

/// A plan rectangle: centre, unit long axis, half extents [m].
struct PlanRect {
  Eigen::Vector2d c, u;
  double hl = 0.0, hs = 0.0;
};

bool overlap(const PlanRect& a, const PlanRect& b) {
  const auto half = [](const PlanRect& r, const Eigen::Vector2d& d) {
    return r.hl * std::abs(r.u.dot(d)) + r.hs * std::abs(Eigen::Vector2d(-r.u.y(), r.u.x()).dot(d));
  };
  const Eigen::Vector2d d = b.c - a.c;
  for (const Eigen::Vector2d& axis :
       {a.u, Eigen::Vector2d(-a.u.y(), a.u.x()), b.u, Eigen::Vector2d(-b.u.y(), b.u.x())})
    if (std::abs(d.dot(axis)) >= half(a, axis) + half(b, axis)) return false;
  return true;
}

PlanRect rect_of(const sim::SimBox& b) {
  return {b.center, Eigen::Vector2d(std::cos(b.yaw_rad), std::sin(b.yaw_rad)), 0.5 * b.long_m,
          0.5 * b.short_m};
}

double layer_top(const sim::Scene& s) {
  double z = s.top_z_m;
  for (const std::size_t i : s.top_layer) z = std::max(z, s.boxes[i].top_z_m);
  return z;
}

/// Scene parts standing higher than the layer by more than `margin_m`.
std::vector<PlanRect> higher_parts(const sim::Scene& s, double margin_m) {
  std::vector<PlanRect> out;
  const double top = layer_top(s);
  for (std::size_t i = 0; i < s.boxes.size(); ++i)
    if (std::find(s.top_layer.begin(), s.top_layer.end(), i) == s.top_layer.end() &&
        s.boxes[i].top_z_m > top + margin_m)
      out.push_back(rect_of(s.boxes[i]));
  return out;
}

/// The truth's picks: plan_picks() on the true boxes (layer frame = world at the layer's top)
/// with the true higher parts as obstacles (their plan on a 5 mm grid) and the camera's view.
std::vector<DetectedBox> truth_plan(const sim::Scene& s, const Intrinsics& intrinsics,
                                    const std::optional<RegionOfInterest>& roi,
                                    const GripperParams& gripper) {
  std::vector<DetectedBox> boxes;
  for (const std::size_t i : s.top_layer) {
    const sim::SimBox& b = s.boxes[i];
    DetectedBox& d = boxes.emplace_back();
    d.in_layer.center = b.center;
    d.in_layer.yaw_rad = b.yaw_rad;
    d.in_layer.long_m = b.long_m;
    d.in_layer.short_m = b.short_m;
    d.in_layer.format = b.format_index;
  }
  // The configured order detect() starts from: far corner first, from the base origin (the
  // simulator's base is the pallet's centre).
  for (DetectedBox& d : boxes)
    d.base_position = Eigen::Vector3d(d.in_layer.center.x(), d.in_layer.center.y(), 0.0);
  sort_by_pick_order(boxes, PickOrder::kFarCornerFirst);
  PickSurroundings surroundings;
  surroundings.T_camera_layer = s.T_world_camera.inverse() * Eigen::Translation3d(0.0, 0.0, layer_top(s));
  surroundings.roi = roi;
  surroundings.T_base_camera = s.T_world_camera;
  surroundings.intrinsics = intrinsics;  // what the camera cannot see cannot be called free
  for (const PlanRect& r : higher_parts(s, 1e-3 * gripper.obstacle_height_mm)) {
    const Eigen::Vector2d v(-r.u.y(), r.u.x());
    for (double a = -r.hl; a <= r.hl; a += 0.005)
      for (double b = -r.hs; b <= r.hs; b += 0.005)
        surroundings.obstacles_layer_m.push_back(r.c + a * r.u + b * v);
  }
  (void)plan_picks(surroundings, gripper, boxes);
  return boxes;
}

struct Tally {
  int frames = 0, ok = 0, exact = 0, picks = 0, violations = 0, neighbour_overlaps = 0;
  int truth_pickable = 0, found_pickable = 0, reported_pickable = 0, false_pickable = 0;
  std::vector<double> plan_ms;
};

void score_frame(const sim::SimulatedFrame& f, const Detection& d, const GripperParams& g,
                 const std::optional<RegionOfInterest>& roi, Tally& t) {
  ++t.frames;
  if (d.status != DetectionStatus::kOk) return;
  ++t.ok;
  if (const auto it = d.timing_ms.find("picking"); it != d.timing_ms.end()) {
    t.plan_ms.push_back(it->second);
    if (std::getenv("PALLETD_BENCH_VERBOSE") != nullptr && it->second > 5.0)
      std::fprintf(stderr, "%s: planning took %.1f ms for %zu boxes\n", f.name.c_str(), it->second,
                   d.boxes.size());
  }
  const std::vector<PlanRect> higher = higher_parts(f.scene, 0.0);
  std::vector<PlanRect> truth_boxes;
  for (const std::size_t i : f.scene.top_layer) truth_boxes.push_back(rect_of(f.scene.boxes[i]));
  for (const PickGroup& group : d.groups) {
    ++t.picks;
    const double yaw = group.tcp.yaw_deg * M_PI / 180.0;
    const Eigen::Vector2d u(std::cos(yaw), std::sin(yaw));
    const Eigen::Vector2d tcp = group.tcp.position_m.head<2>();
    const Eigen::Vector2d c =
        tcp - 1e-3 * (g.tcp_offset_mm.x() * u + g.tcp_offset_mm.y() * Eigen::Vector2d(-u.y(), u.x()));
    const PlanRect footprint{c, u, 0.5e-3 * g.footprint_mm.x(), 0.5e-3 * g.footprint_mm.y()};
    if (std::any_of(higher.begin(), higher.end(), [&](const PlanRect& r) { return overlap(footprint, r); })) {
      ++t.violations;
      if (std::getenv("PALLETD_BENCH_VERBOSE") != nullptr) {
        std::fprintf(stderr, "%s: VIOLATION footprint at (%.3f, %.3f) yaw %.1f over a higher part\n",
                     f.name.c_str(), c.x(), c.y(), group.tcp.yaw_deg);
        for (const PlanRect& r : higher)
          std::fprintf(stderr, "   higher part at (%.3f, %.3f) half %.3f x %.3f\n", r.c.x(), r.c.y(), r.hl,
                       r.hs);
        std::fprintf(stderr, "   %dx%d group of %zu, first box pickable %d\n", f.frame.intrinsics.width,
                     f.frame.intrinsics.height, group.boxes.size(),
                     static_cast<int>(d.boxes[static_cast<std::size_t>(group.boxes[0])].pick->pickable));
        for (const DetectedBox& b : d.boxes)
          std::fprintf(stderr, "   box (%.3f, %.3f) yaw %.1f pickable %d %s tcp (%.3f %.3f)\n",
                       b.base_position->x(), b.base_position->y(), *b.base_yaw_deg,
                       static_cast<int>(b.pick->pickable), to_string(b.pick->blocked_by),
                       b.pick->tcp.position_m.x(), b.pick->tcp.position_m.y());
      }
    }
    // Truth boxes under the footprint (shrunk by the 5 mm tolerance) other than the group's.
    PlanRect inner = footprint;
    inner.hl -= 0.005;
    inner.hs -= 0.005;
    int under = 0;
    for (const PlanRect& r : truth_boxes) under += overlap(inner, r) ? 1 : 0;
    if (under > static_cast<int>(group.boxes.size())) ++t.neighbour_overlaps;
  }
  if (const char* dump = std::getenv("PALLETD_BENCH_DUMP");
      dump != nullptr && f.name.rfind(std::string(dump) + " ", 0) == 0) {
    for (const DetectedBox& b : d.boxes)
      std::fprintf(stderr, "  det (%.4f, %.4f) yaw %.2f size %.4f x %.4f pickable %d %s\n",
                   b.base_position->x(), b.base_position->y(), *b.base_yaw_deg, b.long_m, b.short_m,
                   static_cast<int>(b.pick->pickable), to_string(b.pick->blocked_by));
    for (const std::size_t i : f.scene.top_layer) {
      const sim::SimBox& b = f.scene.boxes[i];
      std::fprintf(stderr, "  true (%.4f, %.4f) yaw %.2f size %.4f x %.4f\n", b.center.x(), b.center.y(),
                   b.yaw_rad * 180.0 / M_PI, b.long_m, b.short_m);
    }
    for (const PickGroup& gr : d.groups) std::fprintf(stderr, "  group of %zu\n", gr.boxes.size());
  }
  const FrameEval e = evaluate_frame(d, f.truth, {});
  if (!e.exact) return;
  ++t.exact;
  // Pickable in truth with room to spare beyond the clearance, 10 mm or two pixel pitches at the
  // layer's range and the 5 mm obstacle grid (an obstacle's edge is as certain as the pixels that
  // see it; stereo cameras grow foreground by 1-2 pixels): the boxes a detection must still call
  // pickable.
  const double range_m = f.scene.T_world_camera.translation().z() - layer_top(f.scene);
  const double pitch_mm = 1e3 * range_m / f.frame.intrinsics.fx;
  GripperParams with_margin = g;
  with_margin.clearance_mm += std::max(10.0, 2.0 * pitch_mm + 5.0);
  const std::vector<DetectedBox> truth = truth_plan(f.scene, f.frame.intrinsics, roi, with_margin);
  for (const DetectedBox& tb : truth) {
    const Eigen::Vector2d c = tb.in_layer.center;
    const auto match =
        std::min_element(d.boxes.begin(), d.boxes.end(), [&](const DetectedBox& a, const DetectedBox& b) {
          return (a.base_position->head<2>() - c).norm() < (b.base_position->head<2>() - c).norm();
        });
    const bool reported = match != d.boxes.end() && match->pick && match->pick->pickable;
    if (std::getenv("PALLETD_BENCH_VERBOSE") != nullptr && tb.pick->pickable != reported)
      std::fprintf(stderr, "%s [%.0fx%.0f/%d]: box at (%.3f, %.3f) truth %s, reported %s (%s)\n",
                   f.name.c_str(), g.footprint_mm.x(), g.footprint_mm.y(), g.max_boxes, c.x(), c.y(),
                   tb.pick->pickable ? "pickable" : to_string(tb.pick->blocked_by),
                   reported ? "pickable" : "blocked", match->pick ? to_string(match->pick->blocked_by) : "-");
    if (tb.pick->pickable) {
      ++t.truth_pickable;
      t.found_pickable += reported ? 1 : 0;
    } else if (reported) {
      ++t.false_pickable;
    }
    t.reported_pickable += reported ? 1 : 0;
  }
}

GripperParams gripper_for(int kind, const sim::Scene& s) {
  const sim::BoxFormatSpec& f = s.recipe.front();
  GripperParams g;
  g.footprint_mm = Eigen::Vector2d(1e3 * f.long_m, 1e3 * f.short_m);
  g.clearance_mm = 20.0;
  if (kind == 1) {
    g.footprint_mm.x() = 2e3 * f.long_m + 20.0;
    g.max_boxes = 2;
  } else if (kind == 2) {
    g.footprint_mm += Eigen::Vector2d(100.0, 100.0);
    g.clearance_mm = 10.0;
  }
  return g;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  const char* kinds[3] = {"box size", "two boxes", "box + 100 mm"};
  const std::vector<sim::SceneFamily> families = {sim::SceneFamily::kIsolated, sim::SceneFamily::kCell,
                                                  sim::SceneFamily::kStepped};
  const std::vector<std::string> profiles = {"helios2", "blaze101", "d435", "o3d303"};
  const std::vector<sim::PatternFamily> patterns = {
      sim::PatternFamily::kBlock, sim::PatternFamily::kInterlock, sim::PatternFamily::kBrick,
      sim::PatternFamily::kPinwheel, sim::PatternFamily::kChimney};
  Tally tallies[3];
  for (int i = 0; i < args.count; ++i) {
    const std::uint64_t seed = sim::frame_seed(args.seed, static_cast<std::uint64_t>(i));
    const sim::SensorProfile profile =
        *sim::profile_by_name(profiles[static_cast<std::size_t>(i / 3) % profiles.size()]);
    sim::ScenarioOptions o;
    o.scene = families[static_cast<std::size_t>(i) % families.size()];
    o.pattern = patterns[static_cast<std::size_t>(i / 12) % patterns.size()];
    o.pallet_stops = true;
    o.fill = o.scene == sim::SceneFamily::kStepped ? 1.0 : 0.6 + 0.4 * static_cast<double>(seed % 5) / 4.0;
    o.removal = sim::RemovalMode::kRandom;
    const Expected<sim::Scene> scene = sim::make_scene(o, profile, seed);
    if (!scene) continue;
    sim::SimulatedFrame f = sim::render(*scene, profile, seed);
    f.name =
        std::to_string(i) + " " + sim::to_string(o.scene) + " " + profile.name + " " + scene->description;
    std::optional<RegionOfInterest> roi;
    if (scene->has_roi)
      roi = RegionOfInterest{RegionOfInterest::Frame::kBase, scene->roi_min_m, scene->roi_max_m};
    std::vector<BoxFormat> formats;
    for (const auto& r : scene->recipe) formats.push_back(BoxFormat{r.long_m, r.short_m, r.name, 0.0});
    for (int k = 0; k < 3; ++k) {
      DetectionParams params;
      params.roi = roi;
      params.gripper = gripper_for(k, *scene);
      const Detection d = detect(f.frame, formats, params);
      score_frame(f, d, *params.gripper, roi, tallies[k]);
    }
  }
  std::printf(
      "| gripper | frames | ok | exact | picks now | picks over a higher part | picks over a neighbour | "
      "truth pickable (exact frames) | reported pickable of them | pickable reported, not in truth | "
      "planning median ms | p95 ms |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int k = 0; k < 3; ++k) {
    const Tally& t = tallies[k];
    std::printf("| %s | %d | %d | %d | %d | %d | %d | %d | %d (%.1f %%) | %d | %.2f | %.2f |\n", kinds[k],
                t.frames, t.ok, t.exact, t.picks, t.violations, t.neighbour_overlaps, t.truth_pickable,
                t.found_pickable, t.truth_pickable > 0 ? 100.0 * t.found_pickable / t.truth_pickable : 0.0,
                t.false_pickable, percentile(t.plan_ms, 50.0), percentile(t.plan_ms, 95.0));
  }
  return 0;
}
