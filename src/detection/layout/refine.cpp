// refine_layout(): a joint fit of all boxes of a layout component in its layout frame. Each box
// side is measured where the evidence is: a side on the outline from the box's own layer points
// (walked outward to the first gap), a side shared with a neighbour from the seam raster (the
// box's own edge of the seam band, depth or intensity); every side is a robust line fit
// (refine_joint.cpp). Sides with a neighbour but no visible seam make the two boxes touch.
// Centres and sizes of all boxes are then one least-squares fit with the nominal format as a
// prior on each size (sizes stay within the tolerance); the per-box yaw follows the fitted
// side slopes. Where an edge lies within the pixel footprint depends on whether the side faces
// the camera (its wall hides the floor behind it) or not: each side's samples are corrected by
// half a footprint accordingly (outline_footprint_correction, seam_footprint_correction); where
// the camera left the mixed pixels straddling an outline edge, their depth places the edge.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "layout_internal.hpp"
#include "layout_scoring.hpp"
#include "refine_joint.hpp"
#include "side_samples.hpp"

namespace palletd {

using namespace layout_detail;

namespace {

/// The smallest depth step beyond a box side that hides the floor behind its wall: the
/// smallest box height a pallet layer has [m].
constexpr double kMinDrop_m = 0.1;

/// An outline stretch with nothing seen beyond it within this is where the depth ends, not a box
/// edge (LayerParams::unobserved_gap_m's default) [m].
constexpr double kUnseenGap_m = 0.05;

/// The steepest side slope taken from a fit: boxes of a layer stand within a few degrees of the
/// orientation the search found (a box turned further is not refined, below).
const double kMaxSideSlope = std::tan(5.0 * M_PI / 180.0);

/// Layer points binned in a coarse grid so that each box only visits its neighbourhood.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector2f>& pts, double cell) : pts_(pts), cell_(cell) {
    if (pts.empty()) return;
    x0_ = y0_ = 1e300;
    double x1 = -1e300, y1 = -1e300;
    for (const auto& p : pts) {
      x0_ = std::min(x0_, static_cast<double>(p.x())); x1 = std::max(x1, static_cast<double>(p.x()));
      y0_ = std::min(y0_, static_cast<double>(p.y())); y1 = std::max(y1, static_cast<double>(p.y()));
    }
    w_ = static_cast<int>((x1 - x0_) / cell_) + 1;
    h_ = static_cast<int>((y1 - y0_) / cell_) + 1;
    bins_.assign(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_), {});
    for (std::size_t i = 0; i < pts.size(); ++i) bins_[bin(pts[i].x(), pts[i].y())].push_back(static_cast<std::uint32_t>(i));
  }
  template <typename F>
  void visit(double x0, double y0, double x1, double y1, F&& f) const {
    if (bins_.empty()) return;
    const int c0 = std::clamp(static_cast<int>((x0 - x0_) / cell_), 0, w_ - 1);
    const int c1 = std::clamp(static_cast<int>((x1 - x0_) / cell_), 0, w_ - 1);
    const int r0 = std::clamp(static_cast<int>((y0 - y0_) / cell_), 0, h_ - 1);
    const int r1 = std::clamp(static_cast<int>((y1 - y0_) / cell_), 0, h_ - 1);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        for (auto i : bins_[static_cast<std::size_t>(r) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(c)]) f(pts_[i]);
      }
    }
  }

 private:
  std::size_t bin(double x, double y) const {
    const int c = std::clamp(static_cast<int>((x - x0_) / cell_), 0, w_ - 1);
    const int r = std::clamp(static_cast<int>((y - y0_) / cell_), 0, h_ - 1);
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(c);
  }
  const std::vector<Eigen::Vector2f>& pts_;
  double cell_;
  double x0_ = 0, y0_ = 0;
  int w_ = 0, h_ = 0;
  std::vector<std::vector<std::uint32_t>> bins_;
};

/// Huber weights (times the inverse variances) of side turns around their common turn: a side
/// whose slope is off by more than two of its sigmas counts less.
template <typename Turn>
std::vector<double> huber_turn_weights(const std::vector<Turn>& turns) {
  std::vector<double> w(turns.size());
  for (std::size_t i = 0; i < turns.size(); ++i) w[i] = turns[i].weight;
  for (int it = 0; it < 8; ++it) {
    double sw = 0, sp = 0;
    for (std::size_t i = 0; i < turns.size(); ++i) {
      sw += w[i];
      sp += w[i] * turns[i].phi_rad;
    }
    if (!(sw > 0)) break;
    const double common = sp / sw;
    for (std::size_t i = 0; i < turns.size(); ++i) {
      const double z = std::abs(turns[i].phi_rad - common) * std::sqrt(turns[i].weight);
      w[i] = turns[i].weight * (z > 2.0 ? 2.0 / z : 1.0);
    }
  }
  return w;
}

}  // namespace

LayoutResult refine_layout(const LayoutResult& found, const LayerResult& layer,
                           const std::vector<BoxFormat>& formats, const SeamEvidence* seams,
                           const LayoutParams& params, const LayerSurroundings* surroundings,
                           const std::vector<RimPixel>* rim) {
  LayoutResult out = found;
  if (found.status != DetectionStatus::ok || found.boxes.empty()) return out;
  double layer_area = 0;
  for (const auto& p : layer.polygons) layer_area += area(p);
  const double pitch = layer.points_2d.empty() ? 0.003
                       : std::sqrt(layer_area / static_cast<double>(layer.points_2d.size()));
  const PointGrid grid(layer.points_2d, 0.05);
  const double m = params.seam_margin_m;
  const bool use_seams = seams != nullptr && !seams->empty() && seams->strength > 0;
  // How far a side may lie from where the search put it: the search packs nominal boxes
  // without gaps, so interior sides are off by the gaps and size deviations accumulated.
  const double window = std::max(0.03, 2.5 * m);
  // The camera in the layer frame: which box sides face it decides where an edge lies within
  // the pixel footprint (refine_joint.hpp). Unknown (no camera above the plane): no correction.
  const Eigen::Vector3d camera_layer = layer.T_camera_layer.inverse().translation();
  const bool view_known = camera_layer.z() > 0.1;
  const double yaw_sigma_rad = params.refine_yaw_sigma_deg * M_PI / 180.0;
  const double w_prior = yaw_sigma_rad > 0 ? 1.0 / (yaw_sigma_rad * yaw_sigma_rad) : 1e300;

  struct ComponentFrame {
    bool built = false;
    LayoutFrame frame;
    PolygonWithHoles polygon;  ///< in the frame
    SeamTable table;
  };
  std::vector<ComponentFrame> frames(layer.polygons.size());
  // Each component's measured orientation (its frame plus its common turn) and the weight of
  // that measurement; each refined box's own turn against its component (NaN: not refined).
  std::vector<double> comp_turn(layer.polygons.size(), 0.0), comp_w(layer.polygons.size(), 0.0);
  std::vector<double> box_turn(out.boxes.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<std::vector<std::size_t>> members(layer.polygons.size());
  for (std::size_t bi = 0; bi < out.boxes.size(); ++bi) {
    const auto ci = static_cast<std::size_t>(found.box_component[bi]);
    if (ci < layer.polygons.size()) members[ci].push_back(bi);
  }
  for (std::size_t ci = 0; ci < members.size(); ++ci) {
    if (members[ci].empty()) continue;
    ComponentFrame& cf = frames[ci];
    cf.built = true;
    double theta = std::fmod(out.boxes[members[ci].front()].yaw_rad, M_PI / 2);
    if (theta < 0) theta += M_PI / 2;
    cf.frame.theta_rad = theta;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& v : layer.polygons[ci].outer) c += v;
    if (!layer.polygons[ci].outer.empty()) c /= static_cast<double>(layer.polygons[ci].outer.size());
    cf.frame.pivot = c;
    cf.polygon = cf.frame.to_frame(layer.polygons[ci]);
    Rect b{1e300, 1e300, -1e300, -1e300};
    for (const auto& v : cf.polygon.outer) {
      b.x0 = std::min(b.x0, v.x()); b.x1 = std::max(b.x1, v.x());
      b.y0 = std::min(b.y0, v.y()); b.y1 = std::max(b.y1, v.y());
    }
    if (use_seams) cf.table = SeamTable(*seams, cf.frame, Rect{b.x0 - 2 * m, b.y0 - 2 * m, b.x1 + 2 * m, b.y1 + 2 * m});

    // The joint fit of this component's boxes.
    const auto& idx = members[ci];
    const std::size_t n = idx.size();
    std::vector<JointBox> jb(n);
    std::vector<bool> along_x(n);
    std::vector<double> local_pitch(n, pitch);
    std::vector<std::vector<Eigen::Vector2d>> local(n);
    std::vector<std::vector<Eigen::Vector3d>> local_rim(n);  // (x, y) in the frame, top share
    std::vector<Eigen::Vector3d> rim_frame;  // the whole rim in this component's frame
    if (rim != nullptr) {
      rim_frame.reserve(rim->size());
      for (const RimPixel& r : *rim) {
        const Eigen::Vector2d q = cf.frame.to_frame(Eigen::Vector2d(r.at_m.cast<double>()));
        rim_frame.emplace_back(q.x(), q.y(), static_cast<double>(r.top_share));
      }
    }
    for (std::size_t k = 0; k < n; ++k) {
      const Box2d& box = out.boxes[idx[k]];
      along_x[k] = std::abs(std::remainder(box.yaw_rad - theta, M_PI)) < M_PI / 4;
      jb[k].center = cf.frame.to_frame(box.center);
      double nl = box.long_m, ns = box.short_m;
      if (box.format >= 0 && static_cast<std::size_t>(box.format) < formats.size()) {
        nl = formats[static_cast<std::size_t>(box.format)].long_m;
        ns = formats[static_cast<std::size_t>(box.format)].short_m;
      }
      jb[k].half = along_x[k] ? Eigen::Vector2d(box.long_m / 2, box.short_m / 2) : Eigen::Vector2d(box.short_m / 2, box.long_m / 2);
      jb[k].half_nominal = along_x[k] ? Eigen::Vector2d(nl / 2, ns / 2) : Eigen::Vector2d(ns / 2, nl / 2);
      // Points a gap beyond the window: an outline edge is seen where its points end.
      const double collect = window + 5.0 * pitch;
      const double reach = jb[k].half.norm() + collect;
      std::size_t inside = 0;
      grid.visit(box.center.x() - reach, box.center.y() - reach, box.center.x() + reach, box.center.y() + reach,
                 [&](const Eigen::Vector2f& p) {
                   const Eigen::Vector2d q = cf.frame.to_frame(Eigen::Vector2d(p.cast<double>()));
                   const Eigen::Vector2d d = (q - jb[k].center).cwiseAbs();
                   if (d.x() > jb[k].half.x() + collect || d.y() > jb[k].half.y() + collect) return;
                   local[k].push_back(q);
                   if (d.x() < jb[k].half.x() - window && d.y() < jb[k].half.y() - window) ++inside;
                 });
      for (const Eigen::Vector3d& r : rim_frame) {
        const Eigen::Vector2d d = (r.head<2>() - jb[k].center).cwiseAbs();
        if (d.x() > jb[k].half.x() + collect || d.y() > jb[k].half.y() + collect) continue;
        local_rim[k].push_back(r);
      }
      const double inner_area = std::max(0.0, 2 * (jb[k].half.x() - window)) * std::max(0.0, 2 * (jb[k].half.y() - window));
      if (inside > 50) local_pitch[k] = std::sqrt(inner_area / static_cast<double>(inside));
    }
    std::vector<SideObservation> sides;
    std::vector<Contact> contacts, neighbours;
    // unseen[k][axis][side]: a side with layer beyond it where no seam was measured.
    std::vector<std::array<std::array<bool, 2>, 2>> unseen(n);
    struct SideTurn {
      std::size_t box;
      double phi_rad, weight;  ///< the side's turn of its box and 1 / variance
    };
    std::vector<SideTurn> turns;
    for (std::size_t k = 0; k < n; ++k) {
      const double lp = local_pitch[k];
      for (int axis = 0; axis < 2; ++axis) {
        const double win_in = std::min(window, 0.4 * jb[k].half[axis]);
        for (int si = 0; si < 2; ++si) {
          const int sign = si == 0 ? -1 : 1;
          unseen[k][static_cast<std::size_t>(axis)][static_cast<std::size_t>(si)] = false;
          const SideRef s = side_of(jb[k], axis, sign, m);
          if (s.hi <= s.lo) continue;
          const double a0 = s.pos + sign * m, a1 = s.pos + sign * 3 * m;
          const Rect beyond = axis == 0 ? Rect{std::min(a0, a1), s.lo, std::max(a0, a1), s.hi}
                                        : Rect{s.lo, std::min(a0, a1), s.hi, std::max(a0, a1)};
          const bool shared = clipped_area(cf.polygon, beyond.x0, beyond.y0, beyond.x1, beyond.y1) > 0.5 * beyond.area();
          // Tan of the viewing angle at the side's middle, outward (> 0: the side faces the camera).
          double view_slope = 0.0;
          if (view_known) {
            Eigen::Vector2d mid, out_dir = Eigen::Vector2d::Zero();
            mid[axis] = s.pos;
            mid[1 - axis] = s.t_ref;
            out_dir[axis] = sign;
            const Eigen::Vector2d mid_l = cf.frame.to_layer(mid);
            const Eigen::Vector2d du = cf.frame.to_layer(out_dir) - cf.frame.to_layer(Eigen::Vector2d::Zero());
            view_slope = du.dot(camera_layer.head<2>() - mid_l) / camera_layer.z();
          }
          const double shift_outline = view_known ? outline_footprint_correction(view_slope, lp, kMinDrop_m) : 0.0;
          // Mixed pixels measure where the edge lies in their footprint unless the side faces the
          // camera (its pixels then mix the top with the wall, not with what lies beyond).
          const std::vector<Eigen::Vector3d>* side_rim = !view_known || view_slope <= 0.0 ? &local_rim[k] : nullptr;
          const double shift_seam = view_known ? sign * seam_footprint_correction(view_slope, lp, kMinDrop_m) : 0.0;
          auto shifted = [](std::vector<Eigen::Vector2d> v, double d) {
            for (auto& q : v) q.y() += d;
            return v;
          };
          std::vector<Eigen::Vector2d> samples;
          double floor_m = 0.3 * lp;
          std::size_t slices = static_cast<std::size_t>((s.hi - s.lo) / (1.5 * lp));
          // Where the depth ends beyond the outline the box's points end without a box edge.
          auto seen = [&](std::vector<Eigen::Vector2d> v) {
            const std::size_t bi = idx[k];
            if (surroundings == nullptr || surroundings->empty() || bi >= found.box_partly_unseen.size() ||
                !found.box_partly_unseen[bi])
              return v;
            Eigen::Vector2d dir = Eigen::Vector2d::Zero();
            dir[axis] = sign;
            const Eigen::Vector2d dir_l = cf.frame.to_layer(dir) - cf.frame.to_layer(Eigen::Vector2d::Zero());
            std::vector<Eigen::Vector2d> kept;
            for (const auto& q : v) {
              Eigen::Vector2d at;
              at[axis] = q.y() + sign * 0.5 * lp;
              at[1 - axis] = q.x();
              if (surroundings->seen_within(cf.frame.to_layer(at), dir_l, kUnseenGap_m)) kept.push_back(q);
            }
            return kept;
          };
          if (!shared || !use_seams) {
            samples = seen(outline_samples(s, local[k], side_rim, lp, window, win_in, shift_outline));
          } else {
            // The box's edge of the seam band; where the raster shows none, where the box's own
            // points end (a hole, a gap the seam raster leaves out).
            samples = shifted(seam_samples(s, *seams, cf.frame, window, win_in), shift_seam);
            const std::vector<Eigen::Vector2d> own = seen(outline_samples(s, local[k], side_rim, lp, window, win_in, shift_outline));
            const double reach_t = 1.5 * lp;
            // Slices where the raster shows no band but the box's points end (a hole).
            std::vector<Eigen::Vector2d> extra;
            for (const auto& q : own) {  // samples are sorted by t
              const auto it = std::lower_bound(samples.begin(), samples.end(), q.x() - reach_t,
                                               [](const Eigen::Vector2d& a, double t) { return a.x() < t; });
              if (it == samples.end() || it->x() > q.x() + reach_t) extra.push_back(q);
            }
            samples.insert(samples.end(), extra.begin(), extra.end());
            floor_m = 0.3 * seams->cell_m;
            slices = static_cast<std::size_t>((s.hi - s.lo) / seams->cell_m);
          }
          const int min_samples = std::max(5, static_cast<int>(0.3 * static_cast<double>(slices)));
          const EdgeLine line = fit_edge_line(samples, s.t_ref, floor_m, min_samples, kMaxSideSlope);
          if (!line.ok) {
            // No seam where too few slices saw one: pressed to the neighbour. A seam seen but
            // too scattered for a line is no contact either.
            const bool seen_seam = samples.size() >= static_cast<std::size_t>(min_samples);
            unseen[k][static_cast<std::size_t>(axis)][static_cast<std::size_t>(si)] = shared && !seen_seam;
            continue;
          }
          // Pixel-scale bias of an edge estimate is not averaged away by many samples.
          const double sigma = std::hypot(line.sigma_offset_m, 0.2 * lp);
          sides.push_back({static_cast<int>(k), axis, sign, line.offset_m, sigma});
          // x-sides: x = c + h - phi (y - cy); y-sides: y = c + h + phi (x - cx).
          const double phi = axis == 0 ? -line.slope : line.slope;
          // The same pixel-scale bias, of opposite sign at the two ends of the stretch, tilts
          // the line however many samples there are. A seam narrower than a pixel darkens the
          // pixel it falls in wherever it lies in it: it is placed to the pixel only, and a
          // whole pixel's step along the side can go unseen (an outline edge is placed within
          // the pixel by the rim's mixed depths and by where the layer points end).
          const double half_stretch = std::max(0.5 * (s.hi - s.lo), lp);
          const double bias_px = shared && use_seams ? 0.5 : 0.2;
          const double sigma_slope = std::hypot(line.sigma_slope, bias_px * lp / half_stretch);
          const double w = 1.0 / (sigma_slope * sigma_slope);
          turns.push_back({k, phi, w});
        }
      }
    }
    // Neighbours pressed together (no seam seen on either side): they touch. Every adjacent
    // pair: solid boxes do not overlap.
    for (std::size_t a = 0; a < n; ++a) {
      for (std::size_t bj = 0; bj < n; ++bj) {
        if (a == bj) continue;
        for (int axis = 0; axis < 2; ++axis) {
          const int o = 1 - axis;
          const double pa = jb[a].center[axis] + jb[a].half[axis], pb = jb[bj].center[axis] - jb[bj].half[axis];
          const double overlap = std::min(jb[a].center[o] + jb[a].half[o], jb[bj].center[o] + jb[bj].half[o]) -
                                 std::max(jb[a].center[o] - jb[a].half[o], jb[bj].center[o] - jb[bj].half[o]);
          if (std::abs(pb - pa) > 2 * m || overlap < 2 * m) continue;
          const double sigma = 0.5 * std::min(local_pitch[a], local_pitch[bj]);
          neighbours.push_back({static_cast<int>(a), static_cast<int>(bj), axis, sigma});
          if (!unseen[a][static_cast<std::size_t>(axis)][1] || !unseen[bj][static_cast<std::size_t>(axis)][0]) continue;
          contacts.push_back({static_cast<int>(a), static_cast<int>(bj), axis, sigma});
        }
      }
    }
    std::vector<JointBox> fitted = jb;
    JointParams jp;
    jp.size_tolerance_m = params.refine_size_tolerance_m;
    jp.size_sigma_m = params.refine_size_tolerance_m / 2;
    solve_joint(fitted, sides, contacts, jp, neighbours);
    // Yaw: the component turns as a whole by the robust (Huber) weighted mean of all side
    // slopes; each box deviates from that by its own slopes, shrunk towards zero by the prior
    // spread of a real box's turn in a layer (a few noisy sides must not turn a box by degrees).
    const std::vector<double> turn_weight = huber_turn_weights(turns);
    std::vector<double> phi_sum(n, 0.0), phi_w(n, 0.0);
    double phi_all = 0, w_all = 0;
    for (std::size_t i = 0; i < turns.size(); ++i) {
      phi_sum[turns[i].box] += turn_weight[i] * turns[i].phi_rad;
      phi_w[turns[i].box] += turn_weight[i];
      phi_all += turn_weight[i] * turns[i].phi_rad;
      w_all += turn_weight[i];
    }
    const double phi_common = w_all > 0 ? phi_all / w_all : 0.0;
    comp_turn[ci] = theta + phi_common;
    comp_w[ci] = w_all;
    for (std::size_t k = 0; k < n; ++k) {
      Box2d& box = out.boxes[idx[k]];
      const Eigen::Vector2d shift = fitted[k].center - jb[k].center;
      if (!fitted[k].center.allFinite() || shift.norm() > 0.25 * box.short_m) continue;  // a wrong association
      box.center = cf.frame.to_layer(fitted[k].center);
      const Eigen::Vector2d size = 2 * fitted[k].half;
      box.long_m = along_x[k] ? size.x() : size.y();
      box.short_m = along_x[k] ? size.y() : size.x();
      box_turn[idx[k]] = w_all > 0 ? (phi_sum[k] - phi_common * phi_w[k]) / (phi_w[k] + w_prior) : 0.0;
    }
  }
  // Separate components of one layer stand on the same pallet pattern: each component's
  // orientation deviates from the layer's (weighted mean, mod 90 deg) by its own evidence,
  // shrunk by the same prior (a one-box component's outline alone must not turn it by degrees).
  double sum_c = 0, sum_s = 0;
  for (std::size_t ci = 0; ci < frames.size(); ++ci) {
    if (!frames[ci].built) continue;
    const double w = comp_w[ci] + 1e-9;
    sum_c += w * std::cos(4 * comp_turn[ci]);
    sum_s += w * std::sin(4 * comp_turn[ci]);
  }
  const double layer_turn = std::atan2(sum_s, sum_c) / 4;
  for (std::size_t bi = 0; bi < out.boxes.size(); ++bi) {
    const auto ci = static_cast<std::size_t>(found.box_component[bi]);
    if (ci >= frames.size() || !frames[ci].built || !std::isfinite(box_turn[bi])) continue;
    const double delta = std::remainder(comp_turn[ci] - layer_turn, M_PI / 2);
    const double turn = layer_turn + delta * comp_w[ci] / (comp_w[ci] + w_prior);
    const double phi = std::remainder(turn - frames[ci].frame.theta_rad, M_PI / 2) + box_turn[bi];
    if (std::abs(phi) < 5.0 * M_PI / 180.0) out.boxes[bi].yaw_rad += phi;
  }
  // Scores and coverage of the refined boxes.
  double covered = 0;
  for (std::size_t bi = 0; bi < out.boxes.size(); ++bi) {
    const auto ci = static_cast<std::size_t>(found.box_component[bi]);
    if (ci >= layer.polygons.size() || !frames[ci].built) continue;
    const ComponentFrame& cf = frames[ci];
    const BoxSupport s = box_support(out.boxes[bi], cf.frame, cf.polygon, cf.table.empty() ? nullptr : &cf.table, params);
    out.box_scores[bi] = s.score;
    covered += s.inside_area_m2;
  }
  if (layer_area > 0) out.coverage = std::min(1.0, covered / layer_area);
  return out;
}

}  // namespace palletd
