// check_pick(): the picked boxes gone, every other box where it was (pick_check.hpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "palletd/core/statistics.hpp"
#include "palletd/core/timing.hpp"
#include "palletd/detection/pick_check.hpp"

#include "../frame_problem.hpp"
#include "../poses.hpp"
#include "check_internal.hpp"

namespace palletd {

const char* to_string(PickVerdict verdict) {
  switch (verdict) {
    case PickVerdict::kPickOk:
      return "pick_ok";
    case PickVerdict::kBoxStillThere:
      return "box_still_there";
    case PickVerdict::kExtraBoxGone:
      return "extra_box_gone";
    case PickVerdict::kNeighbourMoved:
      return "neighbour_moved";
    case PickVerdict::kFailed:
      return "failed";
  }
  return "failed";
}

namespace {

using pick_check::EdgeSample;
using pick_check::Grid;

/// A box's top is looked for inside its outline inset by this much (its edges are rounded and
/// the moved neighbours' overlap it).
constexpr double kCheckInset_m = 0.02;
/// Sides are looked for this far inward and outward of where they were.
constexpr double kReach_m = 0.06;
/// A side's step is read from the top point in the line's cell or a cell beside it: lines
/// within this many cells share pixels.
constexpr double kCorrelatedCells = 2.0;
/// A move counts when it lies beyond 3 sigma of its estimate (squared Mahalanobis length).
constexpr double kSignificance = 9.0;
/// How well the detection placed a side the frame before did not show (a seam not seen): a
/// side the pick laid open is measured against it.
constexpr double kReference_m = 0.004;
constexpr double kReference_rad = 0.6 * M_PI / 180.0;
/// Fewer side samples than this in the frame before (about a side's worth) give no offset.
constexpr std::size_t kMinBiasSamples = 20;
/// Fewer seen cells than this: the box's top was not seen (hidden, no depth), taken as there.
constexpr int kMinSeenCells = 20;
/// A picked box still standing shows its whole top (inset) at the layer's height; less than this
/// share of it and part of its place is open.
constexpr double kWholeTopShare = 0.9;
/// How far a side compared with the frame before may step as a whole from one frame to the next,
/// in pixel pitches (one sigma): the difference of two roundings to a pixel (0.29 pitch each).
constexpr double kPixelShare = 0.4;

std::string frames_problem(const Frame& before, const Frame& after) {
  for (const Frame* f : {&before, &after})
    if (std::string problem = frame_problem(*f); !problem.empty()) return problem;
  if (before.intrinsics.width != after.intrinsics.width ||
      before.intrinsics.height != after.intrinsics.height || before.intrinsics.fx != after.intrinsics.fx ||
      before.intrinsics.fy != after.intrinsics.fy)
    return "the frames come from cameras with other intrinsics";
  return {};
}

/// How the grid's steps sit against the detection's sides in the frame the result came from, for
/// sides facing the camera and sides facing away: a side facing the camera shows the top of its
/// wall within the top's band, beyond the edge, one facing away does not.
struct EdgeBias {
  Eigen::Vector3d camera_layer = Eigen::Vector3d::UnitZ();  ///< the camera in the layer frame [m]
  double facing_m = 0.0, away_m = 0.0;
  /// How far one side's offset may lie from those (one sigma) beyond what the samples show:
  /// half the detection's trim where that stands for them (a stereo camera's fattening varies
  /// between one and two pixels from side to side).
  double spread_m = 0.0;
  /// What the frame before (or an earlier check, LayerDiagnostics) showed of each class.
  std::optional<double> measured_facing_m, measured_away_m;
  [[nodiscard]] bool facing(const Box2d& box, const EdgeSample& s) const {
    const Eigen::Rotation2Dd R(box.yaw_rad);
    const Eigen::Vector2d at = box.center + R * s.point_box;
    return (R * s.normal_box).dot(camera_layer.head<2>() - at) > 0.0;
  }
  [[nodiscard]] double of(const Box2d& box, const EdgeSample& s) const {
    return facing(box, s) ? facing_m : away_m;
  }
};

/// The box moved by `move` (box frame: along its long side, its short side [m], turn [rad]).
DetectedBox moved_box(const DetectedBox& box, const Eigen::Vector3d& move,
                      const Eigen::Isometry3d& T_camera_layer,
                      const std::optional<Eigen::Isometry3d>& T_base_camera) {
  DetectedBox out = box;
  out.in_layer.center += Eigen::Rotation2Dd(box.in_layer.yaw_rad) * move.head<2>();
  out.in_layer.yaw_rad += move.z();
  place_from_layer(out, T_camera_layer, T_base_camera);
  return out;
}

/// One box's side samples (pick_check::edge_samples).
using SideSamples = std::vector<std::optional<EdgeSample>>;

/// The box's move between the two grids. Its sides' steps are found in the frame after the pick
/// around the estimate (three rounds, so a box moved 40 mm is looked for where it went) and
/// compared with where the frame before showed them (`was`, its samples there); a side only the
/// frame after shows (one the pick laid open) is compared with the side as detected, less the
/// offset the frame before shows on average on sides facing the camera as this one does (`bias`).
/// Where nothing was taken (`anything_taken` false: a missed pick), no side was laid open: a side
/// only the frame after shows is a seam read in one frame and not the other, and is left out.
pick_check::Move box_move(const SideSamples& was, const Grid& after, const Box2d& box, const EdgeBias& bias,
                          bool anything_taken, int& sides_seen) {
  const Eigen::Rotation2Dd R(box.yaw_rad);
  const double ref_m = std::hypot(kReference_m, bias.spread_m);  // a laid-open side's reference offset
  pick_check::Move move;
  for (int round = 0; round < 3; ++round) {
    Box2d estimate = box;
    estimate.center += R * move.x.head<2>();
    estimate.yaw_rad += move.x.z();
    const auto now = pick_check::edge_samples(after, estimate, kReach_m);
    // A side only the frame after shows counts where something was taken.
    const auto counts = [&](std::size_t k) { return now[k] && (was[k] || anything_taken); };
    std::vector<EdgeSample> moves;
    int per_side[4] = {0, 0, 0, 0};
    for (std::size_t k = 0; k < now.size(); ++k) {
      if (!counts(k)) continue;
      EdgeSample m = *now[k];
      m.offset_m += pick_check::move_jacobian(m).dot(move.x) - (was[k] ? was[k]->offset_m : bias.of(box, m));
      moves.push_back(m);
      ++per_side[m.side];
    }
    sides_seen = static_cast<int>(
        std::count_if(std::begin(per_side), std::end(per_side), [](int n) { return n >= 3; }));
    move = pick_check::fit_move(moves, kCorrelatedCells * after.cell_m());
    // A side compared with the detected side shares that side's error, an offset (kReference_m,
    // with the offset's spread from side to side) and a turn (kReference_rad) common to its
    // samples: both add to the move's uncertainty. A side compared with the frame before shares
    // where the pixels cut it in each frame: a straight side along a row of pixels steps by a
    // pixel as a whole (kPixelShare of a pitch, one sigma).
    Eigen::Vector3d offset_lever[4], turn_lever[4], pixel_lever[4];
    for (int side = 0; side < 4; ++side)
      offset_lever[side] = turn_lever[side] = pixel_lever[side] = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < now.size(); ++k) {
      if (!counts(k)) continue;
      const EdgeSample& m = *now[k];
      if (was[k]) {
        pixel_lever[m.side] += pick_check::move_jacobian(m);
        continue;
      }
      const double along_m = m.side < 2 ? m.point_box.y() : m.point_box.x();
      offset_lever[m.side] += pick_check::move_jacobian(m);
      turn_lever[m.side] += along_m * pick_check::move_jacobian(m);
    }
    const Eigen::Matrix3d inverse = move.information.inverse();
    const double pixel_m = kPixelShare * after.cell_m();
    for (int side = 0; side < 4; ++side) {
      const Eigen::Vector3d a = inverse * offset_lever[side], b = inverse * turn_lever[side],
                            c = inverse * pixel_lever[side];
      move.covariance += ref_m * ref_m * a * a.transpose() +
                         kReference_rad * kReference_rad * b * b.transpose() +
                         pixel_m * pixel_m * c * c.transpose();
    }
  }
  return move;
}

/// The median offsets of the sides' steps from the detected sides in the frame the result came
/// from, apart for sides facing the camera and away. A class with fewer than kMinBiasSamples
/// samples takes what an earlier check measured on this layer (`layer`'s side steps: the layer
/// shrinks pick by pick, and the sides still seen may all face one way), else the other class's.
/// Where neither shows, `layer.edges_moved_in_m`: how far the detection moved the layer's outline
/// in, where the depth's edges lay outside the intensity image's (a stereo camera's matching
/// window fattens the tops over what lies below them, so a side's step lies that far out; 0
/// where the outline was not moved). `was`: each box's samples in that frame.
EdgeBias edge_bias(const std::vector<SideSamples>& was, const std::vector<DetectedBox>& boxes,
                   const Eigen::Vector3d& camera_layer, const LayerDiagnostics& layer) {
  EdgeBias bias;
  bias.camera_layer = camera_layer;
  std::vector<double> facing, away;
  for (std::size_t i = 0; i < boxes.size(); ++i)
    for (const auto& s : was[i])
      if (s) (bias.facing(boxes[i].in_layer, *s) ? facing : away).push_back(s->offset_m);
  // Too few samples say nothing about the camera's offsets.
  bias.measured_facing_m = facing.size() < kMinBiasSamples ? layer.side_steps_facing_m
                                                           : std::optional(upper_median(std::move(facing)));
  bias.measured_away_m =
      away.size() < kMinBiasSamples ? layer.side_steps_away_m : std::optional(upper_median(std::move(away)));
  if (!bias.measured_facing_m && !bias.measured_away_m) {
    bias.facing_m = bias.away_m = layer.edges_moved_in_m;
    bias.spread_m = 0.5 * layer.edges_moved_in_m;
    return bias;
  }
  bias.facing_m = bias.measured_facing_m.value_or(*bias.measured_away_m);
  bias.away_m = bias.measured_away_m.value_or(*bias.measured_facing_m);
  return bias;
}

/// Each box of the last result, picked or not, and whether its top is still seen where it stood.
std::vector<BoxCheck> presence(const Grid& now, const std::vector<DetectedBox>& boxes,
                               const std::vector<int>& picked) {
  std::vector<BoxCheck> checks;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    BoxCheck c;
    c.box = static_cast<int>(i);
    c.picked = std::find(picked.begin(), picked.end(), c.box) != picked.end();
    int seen_cells = 0;
    c.seen_share = pick_check::top_share(now, boxes[i].in_layer, kCheckInset_m, seen_cells);
    c.present = seen_cells < kMinSeenCells || c.seen_share >= 0.5;
    c.now = boxes[i];
    checks.push_back(std::move(c));
  }
  return checks;
}

/// Presence once more with the moved boxes' tops, where they stand now (grown by the error of
/// their new poses), left out: a neighbour dragged over a picked box's place, whose floor the
/// camera may not see at all (a deep, narrow hole), is not that box still standing.
void recheck_presence(const Grid& now, const std::vector<DetectedBox>& boxes, std::vector<BoxCheck>& checks) {
  constexpr double kMovedPoseError_m = 0.005;
  std::vector<Box2d> moved;
  for (const BoxCheck& c : checks) {
    if (!c.moved) continue;
    Box2d grown = c.now.in_layer;
    grown.long_m += 2.0 * kMovedPoseError_m;
    grown.short_m += 2.0 * kMovedPoseError_m;
    moved.push_back(grown);
  }
  if (moved.empty()) return;
  for (std::size_t i = 0; i < checks.size(); ++i) {
    BoxCheck& c = checks[i];
    if (c.moved || !c.present) continue;
    int seen_cells = 0;
    const double share = pick_check::top_share(now, boxes[i].in_layer, kCheckInset_m, seen_cells, moved);
    if (seen_cells >= kMinSeenCells && share < 0.5) {
      c.present = false;
      c.seen_share = share;
    }
  }
}

PickVerdict verdict_of(const std::vector<BoxCheck>& boxes, std::string& message) {
  PickVerdict verdict = PickVerdict::kPickOk;
  auto worse = [&](PickVerdict v, const std::string& what) {
    if (verdict == PickVerdict::kPickOk || static_cast<int>(v) < static_cast<int>(verdict)) verdict = v;
    message += (message.empty() ? "" : "; ") + what;
  };
  for (const BoxCheck& c : boxes) {
    const std::string name = "box " + std::to_string(c.box);
    if (c.picked && c.present) worse(PickVerdict::kBoxStillThere, name + " was picked but still stands");
    if (!c.picked && !c.present) worse(PickVerdict::kExtraBoxGone, name + " was not picked but is gone");
    if (c.moved) {
      char text[120];
      std::snprintf(text, sizeof text, "%s moved %.1f mm and turned %.1f deg", name.c_str(), c.shift_mm,
                    c.turn_deg);
      worse(PickVerdict::kNeighbourMoved, text);
    }
  }
  return verdict;
}

}  // namespace

PickCheck check_pick(const Frame& before, const Detection& last, const Frame& after,
                     const std::vector<int>& picked, const PickCheckParams& check) {
  const auto t0 = std::chrono::steady_clock::now();
  PickCheck out;
  auto finish = [&](PickVerdict verdict, std::string message) {
    out.verdict = verdict;
    out.message = std::move(message);
    out.timing_ms["total"] = ms_since(t0);
    return out;
  };
  if (last.status != DetectionStatus::kOk || last.boxes.empty())
    return finish(PickVerdict::kFailed, "the last result has no boxes to check against");
  if (std::string problem = frames_problem(before, after); !problem.empty())
    return finish(PickVerdict::kFailed, problem);
  for (const int i : picked)
    if (i < 0 || i >= static_cast<int>(last.boxes.size()))
      return finish(PickVerdict::kFailed, "picked box " + std::to_string(i) + " is not in the last result (" +
                                              std::to_string(last.boxes.size()) + " boxes)");

  // Both frames on one grid over the boxes and around them, in the last layer's frame.
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e9), hi = Eigen::Vector2d::Constant(-1e9);
  for (const DetectedBox& b : last.boxes)
    for (const Eigen::Vector2d& c : b.in_layer.corners()) {
      lo = lo.cwiseMin(c);
      hi = hi.cwiseMax(c);
    }
  lo -= Eigen::Vector2d::Constant(0.1);
  hi += Eigen::Vector2d::Constant(0.1);
  const Eigen::Isometry3d T_layer_camera = last.layer.T_camera_layer.inverse();
  const RayTable rays(after.intrinsics);
  const double cell_m = pick_check::grid_cell_m(after.intrinsics, last.layer);
  Grid was(lo, hi, cell_m), now(lo, hi, cell_m);
  was.add_frame(before, rays, T_layer_camera, pick_check::kBand_m, pick_check::kDrop_m);
  now.add_frame(after, rays, T_layer_camera, pick_check::kBand_m, pick_check::kDrop_m);
  std::vector<SideSamples> samples_before;  // each box's sides in the frame before, once
  samples_before.reserve(last.boxes.size());
  for (const DetectedBox& b : last.boxes)
    samples_before.push_back(pick_check::edge_samples(was, b.in_layer, kReach_m));
  const EdgeBias bias =
      edge_bias(samples_before, last.boxes, T_layer_camera.translation(), last.layer.diagnostics);
  out.side_steps_facing_m = bias.measured_facing_m;
  out.side_steps_away_m = bias.measured_away_m;

  out.boxes = presence(now, last.boxes, picked);
  // Whether anything was taken: a box gone, or a picked box whose top is no longer all seen (a
  // neighbour dragged over its place hides that it is gone).
  const bool anything_taken = std::any_of(out.boxes.begin(), out.boxes.end(), [](const BoxCheck& c) {
    return !c.present || (c.picked && c.seen_share < kWholeTopShare);
  });
  for (std::size_t i = 0; i < last.boxes.size(); ++i) {
    const DetectedBox& box = last.boxes[i];
    BoxCheck& c = out.boxes[i];
    if (c.present && !c.picked) {
      const pick_check::Move move =
          box_move(samples_before[i], now, box.in_layer, bias, anything_taken, c.sides_seen);
      c.shift_mm = 1e3 * move.x.head<2>().norm();
      c.turn_deg = std::abs(move.x.z()) * 180.0 / M_PI;
      // Moved: beyond the tolerance, and beyond what the sides' scatter explains.
      c.moved = (c.shift_mm > check.tolerance_mm || c.turn_deg > check.tolerance_deg) &&
                move.significance() > kSignificance;
      if (c.moved) c.now = moved_box(box, move.x, last.layer.T_camera_layer, before.T_base_camera);
    }
  }
  recheck_presence(now, last.boxes, out.boxes);
  std::string message;
  const PickVerdict verdict = verdict_of(out.boxes, message);
  return finish(verdict, message);
}

}  // namespace palletd
