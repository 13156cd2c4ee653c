// One component's refinement (refine_internal.hpp): its frame, each box's local evidence, each
// box side measured from the outline or the seam band, contacts between pressed neighbours, and
// the joint fit of centres and sizes (refine_joint.cpp).
#include <algorithm>
#include <array>
#include <cmath>

#include "refinement/measured_sizes.hpp"
#include "refinement/refine_internal.hpp"
#include "refinement/refine_joint.hpp"
#include "refinement/rows.hpp"
#include "refinement/side_samples.hpp"

namespace palletd::layout_detail {

namespace {

/// The smallest depth step beyond a box side that hides the floor behind its wall: the
/// smallest box height a pallet layer has [m].
constexpr double kMinDrop_m = 0.1;

/// An outline stretch with nothing seen beyond it within this is where the depth ends, not a box
/// edge (LayerParams::unobserved_gap_m's default) [m].
constexpr double kUnseenGap_m = 0.05;

/// The steepest side slope taken from a fit: boxes of a layer stand within a few degrees of the
/// orientation the search found (a box turned further is not refined).
const double kMaxSideSlope = std::tan(5.0 * M_PI / 180.0);

/// A fit that moves a box by more than this share of its short side took the wrong evidence.
constexpr double kMaxShiftShare = 0.25;

/// A side's turn of its box and 1 / variance.
struct SideTurn {
  std::size_t box;
  double phi_rad, weight;
};

/// The component's frame: its first box's orientation mod 90 deg about its outline's centroid.
ComponentFit component_frame(double first_yaw_rad, const PolygonWithHoles& polygon,
                             const RefineContext& ctx) {
  ComponentFit cf;
  cf.built = true;
  double theta = std::fmod(first_yaw_rad, M_PI / 2);
  if (theta < 0) theta += M_PI / 2;
  cf.frame.theta_rad = theta;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const auto& v : polygon.outer) c += v;
  if (!polygon.outer.empty()) c /= static_cast<double>(polygon.outer.size());
  cf.frame.pivot = c;
  cf.polygon = cf.frame.to_frame(polygon);
  const Rect b = bounds_of(cf.polygon);
  const double m = ctx.params.seams.margin_m;
  if (ctx.seams != nullptr)
    cf.table = SeamTable(*ctx.seams, cf.frame, Rect{b.x0 - 2 * m, b.y0 - 2 * m, b.x1 + 2 * m, b.y1 + 2 * m});
  return cf;
}

/// Each box's nominal and current extent in the frame, where the search put it.
std::vector<BoxEvidence> boxes_in_frame(const std::vector<std::size_t>& idx, const std::vector<LayoutBox>& boxes,
                                        const ComponentFit& cf, const RefineContext& ctx) {
  std::vector<BoxEvidence> ev(idx.size());
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const Box2d& box = boxes[idx[k]];
    BoxEvidence& e = ev[k];
    e.pitch_m = ctx.pitch_m;
    e.along_x = std::abs(std::remainder(box.yaw_rad - cf.frame.theta_rad, M_PI)) < M_PI / 4;
    e.jb.center = cf.frame.to_frame(box.center);
    double nl = box.long_m, ns = box.short_m;
    if (box.format >= 0 && static_cast<std::size_t>(box.format) < ctx.formats.size()) {
      nl = ctx.formats[static_cast<std::size_t>(box.format)].long_m;
      ns = ctx.formats[static_cast<std::size_t>(box.format)].short_m;
    }
    e.jb.half = e.along_x ? Eigen::Vector2d(box.long_m / 2, box.short_m / 2)
                          : Eigen::Vector2d(box.short_m / 2, box.long_m / 2);
    e.jb.half_nominal = e.along_x ? Eigen::Vector2d(nl / 2, ns / 2) : Eigen::Vector2d(ns / 2, nl / 2);
  }
  return ev;
}

/// Each box's extent in the frame (its centre stretched to the outline) and the layer points and
/// rim pixels around it; a box with enough points inside gets the pitch measured on its own top.
std::vector<BoxEvidence> gather_evidence(const std::vector<std::size_t>& idx,
                                         const std::vector<LayoutBox>& boxes, const ComponentFit& cf,
                                         const RefineContext& ctx) {
  std::vector<BoxEvidence> ev = boxes_in_frame(idx, boxes, cf, ctx);
  stretch_to_outline(bounds_of(cf.polygon), ctx.window_m, ctx.params.refine.max_oversize, ev);
  const LayoutFrame::ToFrame to_frame = cf.frame.to_frame_map();
  std::vector<Eigen::Vector3d> rim_frame;  // the whole rim in this component's frame
  if (ctx.rim != nullptr) {
    rim_frame.reserve(ctx.rim->size());
    for (const RimPixel& r : *ctx.rim) {
      const Eigen::Vector2d q = to_frame(Eigen::Vector2d(r.at_m.cast<double>()));
      rim_frame.emplace_back(q.x(), q.y(), static_cast<double>(r.top_share));
    }
  }
  const double window = ctx.window_m;
  // Points a gap beyond the window: an outline edge is seen where its points end.
  const double collect = window + 5.0 * ctx.pitch_m;
  for (BoxEvidence& e : ev) {
    // The layer-frame bounds of the collected rectangle (turned by the frame's theta); 1 um more
    // for the rounding of the frame's transform.
    const double a_x = e.jb.half.x() + collect, a_y = e.jb.half.y() + collect;
    const double c = std::abs(std::cos(cf.frame.theta_rad)), s = std::abs(std::sin(cf.frame.theta_rad));
    const double reach_x = c * a_x + s * a_y + 1e-6, reach_y = s * a_x + c * a_y + 1e-6;
    std::size_t inside = 0;
    const Eigen::Vector2d at = cf.frame.to_layer(e.jb.center);
    ctx.grid.visit(at.x() - reach_x, at.y() - reach_y, at.x() + reach_x, at.y() + reach_y,
                   [&](const Eigen::Vector2f& p) {
                     const Eigen::Vector2d q = to_frame(Eigen::Vector2d(p.cast<double>()));
                     const Eigen::Vector2d d = (q - e.jb.center).cwiseAbs();
                     if (d.x() > e.jb.half.x() + collect || d.y() > e.jb.half.y() + collect) return;
                     e.points.push_back(q);
                     if (d.x() < e.jb.half.x() - window && d.y() < e.jb.half.y() - window) ++inside;
                   });
    for (const Eigen::Vector3d& r : rim_frame) {
      const Eigen::Vector2d d = (r.head<2>() - e.jb.center).cwiseAbs();
      if (d.x() > e.jb.half.x() + collect || d.y() > e.jb.half.y() + collect) continue;
      e.rim.push_back(r);
    }
    const double inner_area =
        std::max(0.0, 2 * (e.jb.half.x() - window)) * std::max(0.0, 2 * (e.jb.half.y() - window));
    if (inside > 50) e.pitch_m = std::sqrt(inner_area / static_cast<double>(inside));
  }
  return ev;
}

/// Tan of the viewing angle at a side's middle, outward (> 0: the side faces the camera).
double view_slope_of(const SideRef& s, int axis, int sign, const ComponentFit& cf, const RefineContext& ctx) {
  Eigen::Vector2d mid, out_dir = Eigen::Vector2d::Zero();
  mid[axis] = s.pos;
  mid[1 - axis] = s.t_ref;
  out_dir[axis] = sign;
  const Eigen::Vector2d mid_l = cf.frame.to_layer(mid);
  const Eigen::Vector2d du = cf.frame.to_layer(out_dir) - cf.frame.to_layer(Eigen::Vector2d::Zero());
  return du.dot(ctx.camera_layer.head<2>() - mid_l) / ctx.camera_layer.z();
}

/// Where the depth ends beyond the outline a box's points end without a box edge: only the
/// samples of a partly unseen box with something seen beyond them within kUnseenGap_m are kept.
std::vector<Eigen::Vector2d> seen_samples(std::vector<Eigen::Vector2d> v, bool partly_unseen, int axis,
                                          int sign, double pitch_m, const ComponentFit& cf,
                                          const RefineContext& ctx) {
  if (ctx.surroundings == nullptr || ctx.surroundings->empty() || !partly_unseen) return v;
  Eigen::Vector2d dir = Eigen::Vector2d::Zero();
  dir[axis] = sign;
  const Eigen::Vector2d dir_l = cf.frame.to_layer(dir) - cf.frame.to_layer(Eigen::Vector2d::Zero());
  std::vector<Eigen::Vector2d> kept;
  for (const auto& q : v) {
    Eigen::Vector2d at;
    at[axis] = q.y() + sign * 0.5 * pitch_m;
    at[1 - axis] = q.x();
    if (ctx.surroundings->seen_within(cf.frame.to_layer(at), dir_l, kUnseenGap_m)) kept.push_back(q);
  }
  return kept;
}

/// One side's measurement: its line, or why there is none.
struct SideResult {
  bool ok = false;
  bool pressed = false;  ///< layer beyond it and no seam seen (-> contact with the neighbour)
  SideObservation observation;
  double phi_rad = 0.0, weight = 0.0;  ///< the side's turn of its box and 1 / variance
};

/// Samples of a side shared with a neighbour: the box's edge of the seam band; where the raster
/// shows none, where the box's own points end (a hole, a gap the seam raster leaves out).
std::vector<Eigen::Vector2d> shared_side_samples(const SideRef& s, const std::vector<Eigen::Vector2d>& own,
                                                 double shift_seam, double win_in, double pitch_m,
                                                 const ComponentFit& cf, const RefineContext& ctx) {
  std::vector<Eigen::Vector2d> samples = seam_samples(s, *ctx.seams, cf.frame, ctx.window_m, win_in);
  for (auto& q : samples) q.y() += shift_seam;
  const double reach_t = 1.5 * pitch_m;
  std::vector<Eigen::Vector2d> extra;
  for (const auto& q : own) {  // samples are sorted by t
    const auto it = std::lower_bound(samples.begin(), samples.end(), q.x() - reach_t,
                                     [](const Eigen::Vector2d& a, double t) { return a.x() < t; });
    if (it == samples.end() || it->x() > q.x() + reach_t) extra.push_back(q);
  }
  samples.insert(samples.end(), extra.begin(), extra.end());
  return samples;
}

/// Measures side (axis, sign) of box k: samples from the outline or the seam band, corrected for
/// where an edge lies within the pixel footprint, and a robust line through them.
SideResult measure_side(const BoxEvidence& e, std::size_t k, int axis, int sign, bool partly_unseen,
                        const ComponentFit& cf, const RefineContext& ctx) {
  SideResult r;
  const double m = ctx.params.seams.margin_m;
  const double lp = e.pitch_m;
  const SideRef s = side_of(e.jb, axis, sign, m);
  if (s.hi <= s.lo) return r;
  const double win_in = std::min(ctx.window_in_m, 0.4 * e.jb.half[axis]);
  const double a0 = s.pos + sign * m, a1 = s.pos + sign * 3 * m;
  const Rect beyond = axis == 0 ? Rect{std::min(a0, a1), s.lo, std::max(a0, a1), s.hi}
                                : Rect{s.lo, std::min(a0, a1), s.hi, std::max(a0, a1)};
  const bool shared =
      clipped_area(cf.polygon, beyond.x0, beyond.y0, beyond.x1, beyond.y1) > 0.5 * beyond.area();
  const double view_slope = ctx.view_known ? view_slope_of(s, axis, sign, cf, ctx) : 0.0;
  const double shift_outline =
      ctx.view_known ? outline_footprint_correction(view_slope, lp, kMinDrop_m) : 0.0;
  // Mixed pixels measure where the edge lies in their footprint unless the side faces the
  // camera (its pixels then mix the top with the wall, not with what lies beyond).
  const std::vector<Eigen::Vector3d>* side_rim = !ctx.view_known || view_slope <= 0.0 ? &e.rim : nullptr;
  const double shift_seam =
      ctx.view_known ? sign * seam_footprint_correction(view_slope, lp, kMinDrop_m) : 0.0;
  const bool from_seams = shared && ctx.seams != nullptr;
  const std::vector<Eigen::Vector2d> own =
      seen_samples(outline_samples(s, e.points, side_rim, lp, ctx.window_m, win_in, shift_outline),
                   partly_unseen, axis, sign, lp, cf, ctx);
  const std::vector<Eigen::Vector2d> samples =
      from_seams ? shared_side_samples(s, own, shift_seam, win_in, lp, cf, ctx) : own;
  const double floor_m = 0.3 * (from_seams ? ctx.seams->cell_m : lp);
  const auto slices = static_cast<std::size_t>((s.hi - s.lo) / (from_seams ? ctx.seams->cell_m : 1.5 * lp));
  const int min_samples = std::max(5, static_cast<int>(0.3 * static_cast<double>(slices)));
  const EdgeLine line = fit_edge_line(samples, s.t_ref, floor_m, min_samples, kMaxSideSlope);
  if (!line.ok) {
    // No seam where too few slices saw one: pressed to the neighbour. A seam seen but too
    // scattered for a line is no contact either.
    r.pressed = shared && samples.size() < static_cast<std::size_t>(min_samples);
    return r;
  }
  r.ok = true;
  // Pixel-scale bias of an edge estimate is not averaged away by many samples.
  const double sigma = std::hypot(line.sigma_offset_m, 0.2 * lp);
  r.observation = {static_cast<int>(k), axis, sign, line.offset_m, sigma};
  // x-sides: x = c + h - phi (y - cy); y-sides: y = c + h + phi (x - cx).
  r.phi_rad = axis == 0 ? -line.slope : line.slope;
  // The same pixel-scale bias, of opposite sign at the two ends of the stretch, tilts the line
  // however many samples there are. A seam narrower than a pixel darkens the pixel it falls in
  // wherever it lies in it: it is placed to the pixel only, and a whole pixel's step along the
  // side can go unseen (an outline edge is placed within the pixel by the rim's mixed depths
  // and by where the layer points end).
  const double half_stretch = std::max(0.5 * (s.hi - s.lo), lp);
  const double bias_px = from_seams ? 0.5 : 0.2;
  const double sigma_slope = std::hypot(line.sigma_slope, bias_px * lp / half_stretch);
  r.weight = 1.0 / (sigma_slope * sigma_slope);
  return r;
}

/// Adjacent boxes: every pair keeps apart (solid boxes do not overlap); pairs pressed together
/// (no seam seen on either side) touch.
void neighbour_contacts(const std::vector<BoxEvidence>& ev,
                        const std::vector<std::array<std::array<bool, 2>, 2>>& pressed, double m,
                        std::vector<Contact>& neighbours, std::vector<Contact>& contacts) {
  const std::size_t n = ev.size();
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t bj = 0; bj < n; ++bj) {
      if (a == bj) continue;
      const JointBox& ja = ev[a].jb;
      const JointBox& jbb = ev[bj].jb;
      for (int axis = 0; axis < 2; ++axis) {
        const int o = 1 - axis;
        const double pa = ja.center[axis] + ja.half[axis], pb = jbb.center[axis] - jbb.half[axis];
        const double overlap = std::min(ja.center[o] + ja.half[o], jbb.center[o] + jbb.half[o]) -
                               std::max(ja.center[o] - ja.half[o], jbb.center[o] - jbb.half[o]);
        if (std::abs(pb - pa) > 2 * m || overlap < 2 * m) continue;
        const double sigma = 0.5 * std::min(ev[a].pitch_m, ev[bj].pitch_m);
        neighbours.push_back({static_cast<int>(a), static_cast<int>(bj), axis, sigma});
        const auto ax = static_cast<std::size_t>(axis);
        if (!pressed[a][ax][1] || !pressed[bj][ax][0]) continue;
        contacts.push_back({static_cast<int>(a), static_cast<int>(bj), axis, sigma});
      }
    }
  }
}

/// Huber weights (times the inverse variances) of side turns around their common turn: a side
/// whose slope is off by more than two of its sigmas counts less.
std::vector<double> huber_turn_weights(const std::vector<SideTurn>& turns) {
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

/// The component's turn and each box's own: the component turns as a whole by the robust
/// (Huber) weighted mean of all side slopes; each box deviates from that by its own slopes,
/// shrunk towards zero by the prior spread of a real box's turn in a layer (a few noisy sides
/// must not turn a box by degrees). Returns each box's own turn; sets cf.turn_*.
std::vector<double> component_turns(const std::vector<SideTurn>& turns, std::size_t n, double w_prior,
                                    ComponentFit& cf) {
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
  cf.turn_rad = cf.frame.theta_rad + phi_common;
  cf.turn_weight = w_all;
  std::vector<double> own(n, 0.0);
  for (std::size_t k = 0; k < n; ++k) {
    own[k] = w_all > 0 ? (phi_sum[k] - phi_common * phi_w[k]) / (phi_w[k] + w_prior) : 0.0;
  }
  return own;
}

}  // namespace

PointGrid::PointGrid(const std::vector<Eigen::Vector2f>& pts, double cell_m) : pts_(pts), cell_(cell_m) {
  if (pts.empty()) return;
  x0_ = y0_ = 1e300;
  double x1 = -1e300, y1 = -1e300;
  for (const auto& p : pts) {
    x0_ = std::min(x0_, static_cast<double>(p.x()));
    x1 = std::max(x1, static_cast<double>(p.x()));
    y0_ = std::min(y0_, static_cast<double>(p.y()));
    y1 = std::max(y1, static_cast<double>(p.y()));
  }
  w_ = static_cast<int>((x1 - x0_) / cell_) + 1;
  h_ = static_cast<int>((y1 - y0_) / cell_) + 1;
  bins_.assign(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_), {});
  for (std::size_t i = 0; i < pts.size(); ++i) {
    bins_[index(row(pts[i].y()), column(pts[i].x()))].push_back(static_cast<std::uint32_t>(i));
  }
}

int PointGrid::column(double x) const { return std::clamp(static_cast<int>((x - x0_) / cell_), 0, w_ - 1); }
int PointGrid::row(double y) const { return std::clamp(static_cast<int>((y - y0_) / cell_), 0, h_ - 1); }

ComponentFit fit_component(const std::vector<std::size_t>& idx, const PolygonWithHoles& polygon,
                           const RefineContext& ctx, double w_prior, std::vector<LayoutBox>& boxes,
                           std::vector<double>& box_turn) {
  ComponentFit cf = component_frame(boxes[idx.front()].yaw_rad, polygon, ctx);
  const std::vector<BoxEvidence> ev = gather_evidence(idx, boxes, cf, ctx);
  const std::size_t n = idx.size();
  std::vector<SideObservation> sides;
  std::vector<SideTurn> turns;
  std::vector<std::array<std::array<bool, 2>, 2>> pressed(n);  // [box][axis][side]
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t bi = idx[k];
    const bool partly_unseen = boxes[bi].partly_unseen;
    for (int axis = 0; axis < 2; ++axis) {
      for (int si = 0; si < 2; ++si) {
        const SideResult r = measure_side(ev[k], k, axis, si == 0 ? -1 : 1, partly_unseen, cf, ctx);
        pressed[k][static_cast<std::size_t>(axis)][static_cast<std::size_t>(si)] = r.pressed;
        if (!r.ok) continue;
        sides.push_back(r.observation);
        turns.push_back({k, r.phi_rad, r.weight});
      }
    }
  }
  std::vector<Contact> contacts, neighbours;
  neighbour_contacts(ev, pressed, ctx.params.seams.margin_m, neighbours, contacts);
  std::vector<JointBox> fitted(n);
  for (std::size_t k = 0; k < n; ++k) fitted[k] = ev[k].jb;
  JointParams jp;
  jp.size_tolerance_m = ctx.params.refine.size_tolerance_m;
  jp.size_sigma_m = ctx.params.refine.size_tolerance_m / 2;
  jp.max_oversize = ctx.params.refine.max_oversize;
  solve_joint(fitted, sides, contacts, jp, neighbours);
  // A gap the fit opened where the layer's points show carton top: the pair touches, fitted again.
  const std::vector<Contact> filled =
      filled_gaps(ev, fitted, contacts, ctx.params.seams.margin_m, ctx.window_m + 4.0 * ctx.pitch_m);
  if (!filled.empty()) {
    contacts.insert(contacts.end(), filled.begin(), filled.end());
    for (std::size_t k = 0; k < n; ++k) fitted[k] = ev[k].jb;
    solve_joint(fitted, sides, contacts, jp, neighbours);
  }
  const std::vector<double> own_turn = component_turns(turns, n, w_prior, cf);
  for (std::size_t k = 0; k < n; ++k) {
    Box2d& box = boxes[idx[k]];
    const Eigen::Vector2d shift = fitted[k].center - ev[k].jb.center;
    if (!fitted[k].center.allFinite() || shift.norm() > kMaxShiftShare * box.short_m) {
      boxes[idx[k]].evidence.fit_rejected = true;  // wrong association
      continue;
    }
    const Eigen::Vector2d measured = measured_extent(sides, k);
    const Eigen::Vector2d run = run_extent(sides, contacts, fitted, k);
    auto& e = boxes[idx[k]].evidence;
    e.fit_rejected = false;
    e.measured_long_m = ev[k].along_x ? measured.x() : measured.y();
    e.measured_short_m = ev[k].along_x ? measured.y() : measured.x();
    e.run_long_m = ev[k].along_x ? run.x() : run.y();
    e.run_short_m = ev[k].along_x ? run.y() : run.x();
    boxes[idx[k]].evidence.position_sigma_m = fitted[k].sigma_center.maxCoeff();
    boxes[idx[k]].evidence.refine_shift_m = shift.norm();
    box.center = cf.frame.to_layer(fitted[k].center);
    const Eigen::Vector2d size = 2 * fitted[k].half;
    box.long_m = ev[k].along_x ? size.x() : size.y();
    box.short_m = ev[k].along_x ? size.y() : size.x();
    box_turn[idx[k]] = own_turn[k];
  }
  return cf;
}

}  // namespace palletd::layout_detail
