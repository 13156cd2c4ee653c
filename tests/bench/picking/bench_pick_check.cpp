// palletd_bench_pick_check [--count N] [--seed S] [--frame I] [--sequence]
// The check after a pick (check_pick) on simulated picks, for docs/benchmarks.md: a layer of
// every pattern seen by four sensor profiles; box 0 of the detected pick order is taken, and by
// turns the pick is clean, missed, a double pick (a neighbour gone too), or a neighbour is
// dragged 5-40 mm toward the gap or turned 2-5 degrees where it has room (sim::simulate_pick).
// With --sequence the layer is picked until it is gone, each check against the result the last
// one left (after_pick), as in the cell. Prints, per profile, how often the check is right (its
// verdict, and no box the pick did not move called moved to where it does not stand), missed and
// double picks called pick_ok, the moved neighbours' pose error and the time per check.
// PALLETD_BENCH_VERBOSE=1 prints every wrong check; PALLETD_BENCH_DETAIL=1 adds, for each box left
// standing, how far the pose checked against was from the truth and what the check read (for
// every check with PALLETD_BENCH_DETAIL_ALL=1 too).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/pick_check.hpp"
#include "palletd/detection/picking.hpp"
#include "palletd/results/evaluation.hpp"
#include "palletd/sim/pick.hpp"
#include "palletd/sim/sim.hpp"

using namespace palletd;

namespace {

struct Tally {
  int checks = 0, right = 0, unsafe_ok = 0, turns_asked = 0, turns_done = 0;
  int misplaced = 0;  ///< checks that put a box the pick did not move somewhere it does not stand
  int per_case[5] = {0, 0, 0, 0, 0}, right_per_case[5] = {0, 0, 0, 0, 0};
  std::vector<double> pose_error_mm, check_ms;

  Tally& operator+=(const Tally& o) {
    checks += o.checks, right += o.right, unsafe_ok += o.unsafe_ok;
    turns_asked += o.turns_asked, turns_done += o.turns_done, misplaced += o.misplaced;
    for (int k = 0; k < 5; ++k) per_case[k] += o.per_case[k], right_per_case[k] += o.right_per_case[k];
    pose_error_mm.insert(pose_error_mm.end(), o.pose_error_mm.begin(), o.pose_error_mm.end());
    check_ms.insert(check_ms.end(), o.check_ms.begin(), o.check_ms.end());
    return *this;
  }
};

/// One row of the table.
void print_row(const std::string& name, const Tally& t) {
  std::printf("| %s | %d | %d | %d/%d | %d/%d | %d/%d | %d/%d | %d/%d | %d | %.1f | %.1f | %.1f | %.1f |\n",
              name.c_str(), t.checks, t.right, t.right_per_case[0], t.per_case[0], t.right_per_case[1],
              t.per_case[1], t.right_per_case[2], t.per_case[2], t.right_per_case[3], t.per_case[3],
              t.right_per_case[4], t.per_case[4], t.unsafe_ok, percentile(t.pose_error_mm, 50.0),
              percentile(t.pose_error_mm, 100.0), percentile(t.check_ms, 50.0), percentile(t.check_ms, 95.0));
}

/// The standing scene box nearest to a detected one.
std::size_t scene_box(const sim::Scene& s, const DetectedBox& b) {
  const Eigen::Vector2d at = b.base_position->head<2>();
  auto distance = [&](std::size_t k) {
    return sim::taken_off(s.boxes[k]) ? 1e9 : (s.boxes[k].center - at).norm();
  };
  return *std::min_element(s.top_layer.begin(), s.top_layer.end(),
                           [&](std::size_t x, std::size_t y) { return distance(x) < distance(y); });
}

/// The detected box standing nearest to `at` (base frame, x-y) [m].
int detected_box(const Detection& d, const Eigen::Vector2d& at) {
  int best = -1;
  double best_d = 1e9;
  for (std::size_t j = 0; j < d.boxes.size(); ++j) {
    const double dist = (d.boxes[j].base_position->head<2>() - at).norm();
    if (dist < best_d) best_d = dist, best = static_cast<int>(j);
  }
  return best;
}

/// Whether the check called a box other than `moved` (the detected box the pick moved, -1 for
/// none) moved to where it does not stand: further than the tolerance from its box in `scene`.
bool misplaces_a_box(const PickCheck& c, const Detection& last, const sim::Scene& scene, int moved) {
  for (std::size_t j = 0; j < c.boxes.size(); ++j) {
    const BoxCheck& b = c.boxes[j];
    if (!b.moved || static_cast<int>(j) == moved) continue;
    const std::size_t k = scene_box(scene, last.boxes[j]);
    if (1e3 * (b.now.base_position->head<2>() - scene.boxes[k].center).norm() >
        PickCheckParams{}.tolerance_mm)
      return true;
  }
  return false;
}

/// For each box left standing: how far the pose checked against lies from its box in `scene`
/// (after the pick), and what the check read (PALLETD_BENCH_DETAIL).
void print_detail(const PickCheck& c, const Detection& last, const sim::Scene& scene,
                  const sim::PickOutcome& outcome, const std::string& label) {
  for (std::size_t j = 0; j < c.boxes.size(); ++j) {
    const BoxCheck& b = c.boxes[j];
    if (b.picked || !b.present) continue;
    const std::size_t k = scene_box(scene, last.boxes[j]);
    const Eigen::Vector2d err = last.boxes[j].base_position->head<2>() - scene.boxes[k].center;
    double yaw_err = *last.boxes[j].base_yaw_deg - scene.boxes[k].yaw_rad * 180.0 / M_PI;
    while (yaw_err > 90.0) yaw_err -= 180.0;
    while (yaw_err < -90.0) yaw_err += 180.0;
    std::fprintf(
        stderr,
        "   %s %s box %zu (scene %zu%s): pose before err %.1f mm %.2f deg | check shift %.1f turn %.2f "
        "sides %d%s\n",
        label.c_str(), sim::to_string(outcome.event), j, k,
        outcome.neighbour && *outcome.neighbour == k ? ", the one moved" : "", 1e3 * err.norm(), yaw_err,
        b.shift_mm, b.turn_deg, b.sides_seen, b.moved ? " MOVED" : "");
  }
}

/// One pick of box 0 of `last` (seen in `before`), made in `scene` by the event `s` draws,
/// checked and scored into `t`. Returns the check and the frame after it.
std::pair<PickCheck, Frame> check_one(const Detection& last, const Frame& before, sim::Scene& scene,
                                      const sim::SensorProfile& profile, std::uint64_t s,
                                      const std::string& label, Tally& t) {
  const int asked = static_cast<int>(s % 4);
  const sim::PickEvent event = asked == 3
                                   ? ((s >> 20) % 3 == 0 ? sim::PickEvent::kTurn : sim::PickEvent::kDrag)
                                   : static_cast<sim::PickEvent>(asked);
  const sim::PickOutcome outcome = sim::simulate_pick(scene, scene_box(scene, last.boxes[0]), event, s);
  const int kind = static_cast<int>(outcome.event);
  t.turns_asked += event == sim::PickEvent::kTurn ? 1 : 0;
  t.turns_done += outcome.event == sim::PickEvent::kTurn ? 1 : 0;
  // The neighbour is matched where it stood before the pick.
  const int other =
      outcome.neighbour ? detected_box(last, scene.boxes[*outcome.neighbour].center - outcome.shift_m) : -1;
  sim::SimulatedFrame frame_after = sim::render(scene, profile, s + 7);
  const PickCheck c = check_pick(before, last, frame_after.frame, {0}, PickCheckParams{});
  ++t.checks;
  ++t.per_case[kind];
  t.check_ms.push_back(c.timing_ms.at("total"));
  const PickVerdict expected[5] = {PickVerdict::kPickOk, PickVerdict::kBoxStillThere,
                                   PickVerdict::kExtraBoxGone, PickVerdict::kNeighbourMoved,
                                   PickVerdict::kNeighbourMoved};
  // A moved neighbour within the tolerance may be reported either way.
  const double moved_mm = 1e3 * outcome.shift_m.norm();
  const double turned_deg = std::abs(outcome.turn_rad) * 180.0 / M_PI;
  const bool moves = kind >= 3;
  const bool small = moves && moved_mm <= 12.0 && turned_deg < 1.0;
  // A box the pick did not move, called moved to where it does not stand, makes the check wrong
  // whatever its verdict: its new pose is published (after_pick).
  const bool misplaced = misplaces_a_box(c, last, scene, other);
  t.misplaced += misplaced ? 1 : 0;
  const bool right =
      !misplaced && (c.verdict == expected[kind] || (small && c.verdict == PickVerdict::kPickOk));
  t.right += right ? 1 : 0;
  t.right_per_case[kind] += right ? 1 : 0;
  if ((kind == 1 || kind == 2) && c.verdict == PickVerdict::kPickOk) ++t.unsafe_ok;
  static const BoxCheck kNone;
  const BoxCheck& seen = other >= 0 ? c.boxes[static_cast<std::size_t>(other)] : kNone;
  if (moves && seen.moved)
    t.pose_error_mm.push_back(
        1e3 * (seen.now.base_position->head<2>() - scene.boxes[*outcome.neighbour].center).norm());
  if (!right && std::getenv("PALLETD_BENCH_VERBOSE") != nullptr)
    std::fprintf(stderr,
                 "%s %s: %s expected, %s: %s (moved %.1f mm, turned %.1f deg; the check saw the "
                 "neighbour move %.1f mm, turn %.1f deg, %d sides seen)\n",
                 label.c_str(), sim::to_string(outcome.event), to_string(expected[kind]),
                 to_string(c.verdict), c.message.c_str(), moved_mm, turned_deg, seen.shift_mm, seen.turn_deg,
                 seen.sides_seen);
  if ((!right || std::getenv("PALLETD_BENCH_DETAIL_ALL") != nullptr) &&
      std::getenv("PALLETD_BENCH_DETAIL") != nullptr)
    print_detail(c, last, scene, outcome, label);
  return {c, std::move(frame_after.frame)};
}

}  // namespace

int main(int argc, char** argv) {
  int count = 80;
  std::uint64_t seed = 1;
  int only = -1;  // --frame: that frame of the set alone (to look at one check)
  for (int i = 1; i + 1 < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--count")
      count = std::atoi(argv[i + 1]);
    else if (k == "--seed")
      seed = std::strtoull(argv[i + 1], nullptr, 10);
    else if (k == "--frame")
      only = std::atoi(argv[i + 1]);
  }
  const bool sequence = std::find(argv + 1, argv + argc, std::string("--sequence")) != argv + argc;
  const std::vector<std::string> profiles = {"helios2", "blaze101", "o3d303", "d435"};
  const std::vector<sim::PatternFamily> patterns = {
      sim::PatternFamily::kBlock, sim::PatternFamily::kInterlock, sim::PatternFamily::kBrick,
      sim::PatternFamily::kPinwheel};
  std::vector<Tally> tallies(profiles.size());
  for (int i = 0; i < count; ++i) {
    if (only >= 0 && i != only) continue;
    const std::uint64_t s = sim::frame_seed(seed, static_cast<std::uint64_t>(i));
    const std::size_t pi = static_cast<std::size_t>(i) % profiles.size();
    const sim::SensorProfile profile = *sim::profile_by_name(profiles[pi]);
    sim::ScenarioOptions o;
    o.pattern = patterns[static_cast<std::size_t>(i / 4) % patterns.size()];
    const Expected<sim::Scene> scene = sim::make_scene(o, profile, s);
    if (!scene) continue;
    const sim::SimulatedFrame before = sim::render(*scene, profile, s);
    std::vector<BoxFormat> formats;
    for (const auto& r : scene->recipe) formats.push_back(BoxFormat{r.long_m, r.short_m, r.name, 0.0});
    const Detection last = detect(before.frame, formats, DetectionParams{});
    if (last.status != DetectionStatus::kOk || last.boxes.size() < 2 ||
        !evaluate_frame(last, before.truth, {}).exact)
      continue;  // the check starts from a right result
    sim::Scene now = *scene;
    Tally& t = tallies[pi];
    const std::string label = std::to_string(i) + " " + profiles[pi];
    if (!sequence) {
      check_one(last, before.frame, now, profile, s, label, t);
      continue;
    }
    // The whole layer, pick after pick, each check against what the last one left.
    Detection d = last;
    Frame f = before.frame;
    for (int step = 0; !d.boxes.empty() && step < 3 * static_cast<int>(last.boxes.size()); ++step) {
      auto [c, next] = check_one(d, f, now, profile, sim::frame_seed(s, static_cast<std::uint64_t>(step) + 1),
                                 label + " pick " + std::to_string(step), t);
      d = after_pick(d, c, next, DetectionParams{});
      f = std::move(next);
    }
  }
  std::printf(
      "| profile | checks | right | clean | missed | double | dragged | turned | missed or double called "
      "pick_ok | moved pose error median mm | max mm | check median ms | p95 ms |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  Tally all;
  for (std::size_t p = 0; p < profiles.size(); ++p) {
    print_row(profiles[p], tallies[p]);
    all += tallies[p];
  }
  print_row("all", all);
  std::printf(
      "\nTurns asked %d, made %d (the rest had no room and were dragged). Checks that put a box the pick did "
      "not move where it does not stand: %d (not right).\n",
      all.turns_asked, all.turns_done, all.misplaced);
  return 0;
}
