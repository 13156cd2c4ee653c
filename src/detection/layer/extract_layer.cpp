// extract_layer(): stages 1-5 composed, with diagnostics and a clear status on bad input.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>

#include "palletd/core/timing.hpp"

#include "layer_stages.hpp"

namespace palletd {
namespace {

using Clock = std::chrono::steady_clock;

/// Crust pruning length when ContourParams::d_max_m is 0 [pitches of the ring].
constexpr double kCrustDMax_pitches = 2.0;
/// A ring enclosing less than this many pixel footprints (pitch^2) is no outline [px].
constexpr double kMinRingArea_px = 2.0;

LayerResult fail(LayerResult result, DetectionStatus status, std::string reason) {
  result.status = status;
  result.reason = std::move(reason);
  result.polygons.clear();
  return result;
}

struct RingGeometry {
  std::vector<Eigen::Vector2d> points;   // border pixels in the layer frame [m]
  std::vector<Eigen::Vector2d> samples;  // midpoints between layer and off-layer 4-neighbours
  std::vector<Eigen::Vector2d> sample_origins;  // the border pixel of each sample (layer frame) [m]
  double pitch_m = 0.0;                  // largest 4-neighbour spacing on this ring [m]
  std::size_t unobserved = 0;            // samples with no depth outside within the gap [count]
};

/// Signed distance of pixel (u, v) to the plane, NaN when outside the image or invalid.
double signed_distance_at(const OrganizedCloud& cloud, const Plane& plane, int u, int v, const PlaneParams& validity) {
  if (u < 0 || v < 0 || u >= cloud.width || v >= cloud.height) return std::nan("");
  const Eigen::Vector3f& p = cloud.at(u, v);
  if (!layer::usable(p, validity)) return std::nan("");
  return plane.signed_distance(p.cast<double>());
}

/// Border pixels of one ring in the layer frame, and edge samples between each border pixel and
/// its off-layer 4-neighbours. A sample lies where the edge crosses the pixel pair: half-way by
/// default; when the depth steps down beyond the edge, the mixed depths of the pair (their share
/// of the top face) move it to sub-pixel precision.
/// Edges facing the camera are seen with the box's side wall below them: wall pixels within the
/// band lie below the plane, and the ray through them meets the plane outside the face (by
/// depth x tan of the view angle). There the measured point, projected along the normal, gives
/// the edge: a wall point projects onto the edge line, a top point onto itself (then the edge is
/// up to half a pixel further out, by how far the point lies below the plane).
RingGeometry ring_geometry(const layer::RingPixels& ring, const cv::Mat& mask, const layer::PixelToLayer& to_layer,
                           const OrganizedCloud& cloud, const Plane& plane, const layer::BandTable& band,
                           const Eigen::Isometry3d& T_layer_camera, const PlaneParams& validity, double fx_px,
                           double gap_m) {
  RingGeometry g;
  g.points.reserve(ring.pixels.size());
  static const int du[4] = {-1, 1, 0, 0};
  static const int dv[4] = {0, 0, -1, 1};
  std::vector<double> spacing;
  const Eigen::Vector2d camera_xy = T_layer_camera.translation().head<2>();
  for (const cv::Point& p : ring.pixels) {
    const Eigen::Vector2d q = to_layer(p.x, p.y);
    g.points.push_back(q);
    const Eigen::Vector3f& pc = cloud.at(p.x, p.y);
    const bool measured = layer::usable(pc, validity);
    const double band_m = static_cast<double>(band.at(pc.z()));
    // A real step down: beyond the fillable zone of twice the band, at least 30 mm.
    const double min_step = -std::max(2.0 * band_m, 0.03);
    for (int k = 0; k < 4; ++k) {
      const int u = p.x + du[k], v = p.y + dv[k];
      const bool inside = u >= 0 && v >= 0 && u < mask.cols && v < mask.rows;
      if (inside && mask.at<std::uint8_t>(v, u) != 0) continue;
      const Eigen::Vector2d o = to_layer(u, v);
      // The outline runs along invalid pixels here when no depth is measured beyond it within
      // unobserved_gap_m (beyond the range, too dark): the layer may go on unseen. A narrower
      // strip (a projector shadow, dropouts at the edge) with a surface seen beyond still shows
      // where the layer ends.
      if (inside && !layer::usable(cloud.at(u, v), validity)) {
        const double z_m = measured ? static_cast<double>(pc.z()) : plane.d;
        const int reach = std::max(2, static_cast<int>(std::ceil(gap_m * fx_px / std::max(z_m, 0.1))));
        bool seen = false;
        for (int j = 2; j <= reach && !seen; ++j) {
          const int uj = p.x + j * du[k], vj = p.y + j * dv[k];
          if (uj < 0 || vj < 0 || uj >= mask.cols || vj >= mask.rows) break;
          seen = layer::usable(cloud.at(uj, vj), validity);
        }
        if (!seen) ++g.unobserved;
      }
      double e = 0.5;
      const double s_far = signed_distance_at(cloud, plane, p.x + 2 * du[k], p.y + 2 * dv[k], validity);
      if (std::isfinite(s_far) && s_far < min_step) {
        const double s_in = signed_distance_at(cloud, plane, p.x, p.y, validity);
        const double s_out = signed_distance_at(cloud, plane, u, v, validity);
        const double beta = std::isfinite(s_in) ? std::clamp(1.0 - s_in / s_far, 0.0, 1.0) : 1.0;
        const double alpha = std::isfinite(s_out) ? std::clamp(1.0 - s_out / s_far, 0.0, 1.0) : 0.0;
        e = std::clamp(beta + alpha - 0.5, 0.0, 1.5);
      }
      const Eigen::Vector2d step = o - q;
      if (measured && step.dot(camera_xy - q) > 0.0) {
        // Edge facing the camera: its wall lies beyond it (no step down to mix with); the
        // projected measured point.
        const Eigen::Vector3d m = T_layer_camera * pc.cast<double>();
        const double w = std::clamp(1.0 + m.z() / band_m, 0.0, 1.0);  // 1 on the top, 0 a band below
        g.samples.push_back(m.head<2>() + 0.5 * w * step);
      } else {
        g.samples.push_back(q + e * step);
      }
      g.sample_origins.push_back(q);
      spacing.push_back((o - q).norm());
    }
  }
  if (!spacing.empty()) {
    const std::size_t i = std::min(spacing.size() - 1, spacing.size() * 9 / 10);
    std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(i), spacing.end());
    g.pitch_m = spacing[i];
  }
  return g;
}

/// Why the frame cannot be used, if it cannot: its intrinsics do not match the cloud, no pixel
/// has a depth, or most depths lie outside [min_depth_m, max_depth_m]. `usable`: the points
/// within that range (counted once the intrinsics match).
std::optional<std::string> frame_problem(const Intrinsics& K, const OrganizedCloud& cloud,
                                         const PlaneParams& plane_params, std::size_t& usable) {
  if (!K.valid() || cloud.width != K.width || cloud.height != K.height ||
      cloud.points.size() != static_cast<std::size_t>(cloud.width) * static_cast<std::size_t>(cloud.height)) {
    return "frame intrinsics and organized cloud do not match";
  }
  std::size_t finite = 0;
  for (const Eigen::Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    ++finite;
    if (layer::usable(p, plane_params)) ++usable;
  }
  if (finite == 0) return "every pixel of the frame is invalid";
  if (usable * 2 < finite) {
    std::ostringstream s;
    s << "most depths are outside [" << plane_params.min_depth_m << ", " << plane_params.max_depth_m
      << "] m (" << (finite - usable) << " of " << finite << " pixels)";
    return s.str();
  }
  return std::nullopt;
}

/// The layer's points: the mask's pixels with a usable depth, row by row, in the layer frame,
/// with their pixel indices.
void collect_layer_points(const cv::Mat& mask, const OrganizedCloud& cloud,
                          const Eigen::Isometry3d& T_layer_camera, const PlaneParams& plane_params,
                          LayerResult& result) {
  const Eigen::Matrix3f R = T_layer_camera.linear().cast<float>();
  const Eigen::Vector3f t = T_layer_camera.translation().cast<float>();
  const auto n_layer = static_cast<std::size_t>(cv::countNonZero(mask));
  result.points_2d.reserve(n_layer);
  result.point_pixels.reserve(n_layer);
  for (int v = 0; v < mask.rows; ++v) {
    const auto* m = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < mask.cols; ++u) {
      if (m[u] == 0) continue;
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (!layer::usable(p, plane_params)) continue;
      result.points_2d.push_back((R * p + t).head<2>());
      result.point_pixels.push_back(v * mask.cols + u);
    }
  }
  result.diagnostics.layer_points = result.points_2d.size();
}

/// The cleaned mask (1 = layer) and the border pixels, for the debug pictures.
void record_mask(const layer::LayerMask& lm, LayerTrace& trace) {
  trace.width = lm.mask.cols;
  trace.height = lm.mask.rows;
  trace.layer_mask.assign(lm.mask.datastart, lm.mask.dataend);
  for (auto& m : trace.layer_mask) m = m != 0 ? 1 : 0;
  trace.border_pixels.clear();
  for (int v = 0; v < lm.border.rows; ++v)
    for (int u = 0; u < lm.border.cols; ++u)
      if (lm.border.at<std::uint8_t>(v, u) != 0) trace.border_pixels.push_back(v * lm.border.cols + u);
}

/// What stage 5 takes from the stages before it.
struct OutlineContext {
  const cv::Mat& mask;
  const layer::PixelToLayer& to_layer;
  const OrganizedCloud& cloud;
  const Plane& plane;
  const layer::BandTable& band;
  const Eigen::Isometry3d& T_layer_camera;
  const PlaneParams& plane_params;
  double fx_px = 0.0;
  const LayerParams& layer_params;
  const ContourParams& contour_params;
  LayerTrace* trace = nullptr;  ///< null: no debug trace
};

/// The outline samples of the rings traced, and those of them whose outside is unobserved.
struct OutlineCounts {
  std::size_t samples = 0;
  std::size_t unobserved = 0;
};

/// The crust through a ring's border pixels (Delaunay edges up to d_max_m), kept in the trace
/// with its edges when there is one.
std::vector<Eigen::Vector2d> crust_of(const RingGeometry& g, const layer::RingPixels& pixels, double d_max_m,
                                      LayerTrace* trace) {
  std::vector<std::pair<int, int>> edges;
  const std::vector<int> order = layer::crust_ring(g.points, pixels.chain, d_max_m, trace ? &edges : nullptr);
  std::vector<Eigen::Vector2d> crust;
  crust.reserve(order.size());
  for (const int i : order) crust.push_back(g.points[static_cast<std::size_t>(i)]);
  if (trace) {
    for (const auto& [a, b] : edges)
      trace->crust_edges.emplace_back(g.points[static_cast<std::size_t>(a)], g.points[static_cast<std::size_t>(b)]);
    trace->crust_rings.push_back(crust);
  }
  return crust;
}

/// One ring's polygon: the crust through its border pixels, simplified (the crust itself when
/// that fails); counter-clockwise for an outer ring, clockwise for a hole. Empty when it encloses
/// less than kMinRingArea_px pixel footprints (e.g. a collapsed sliver). `d_max_used_m`: the
/// longest crust pruning length used so far, raised to this ring's.
Ring2d trace_ring(const OutlineContext& ctx, const layer::RingPixels& pixels, bool hole,
                  OutlineCounts& counts, double& d_max_used_m) {
  const RingGeometry g = ring_geometry(pixels, ctx.mask, ctx.to_layer, ctx.cloud, ctx.plane, ctx.band,
                                       ctx.T_layer_camera, ctx.plane_params, ctx.fx_px,
                                       ctx.layer_params.unobserved_gap_m);
  counts.samples += g.samples.size();
  counts.unobserved += g.unobserved;
  const double d_max =
      ctx.contour_params.d_max_m > 0.0 ? ctx.contour_params.d_max_m : kCrustDMax_pitches * g.pitch_m;
  d_max_used_m = std::max(d_max_used_m, d_max);
  const std::vector<Eigen::Vector2d> crust = crust_of(g, pixels, d_max, ctx.trace);
  Ring2d ring = layer::simplify_ring(crust, g.samples, g.pitch_m, ctx.contour_params, &g.sample_origins);
  if (ring.size() < 3) ring = crust;
  if (ring.size() < 3 || std::abs(signed_area(ring)) < kMinRingArea_px * g.pitch_m * g.pitch_m) return {};
  const double a = signed_area(ring);
  if ((a < 0.0) != hole) std::reverse(ring.begin(), ring.end());
  return ring;
}

/// Stage 5 for every kept component: its outer ring, then its holes. A component whose outer
/// ring is no outline is left out, and so is a hole that is none.
void trace_polygons(const OutlineContext& ctx, const std::vector<layer::Component>& components,
                    LayerResult& result, OutlineCounts& counts) {
  for (const layer::Component& comp : components) {
    PolygonWithHoles poly;
    poly.outer = trace_ring(ctx, comp.outer, false, counts, result.diagnostics.d_max_m);
    if (poly.outer.size() < 3) continue;
    for (const layer::RingPixels& hole : comp.holes) {
      Ring2d ring = trace_ring(ctx, hole, true, counts, result.diagnostics.d_max_m);
      if (ring.size() >= 3) poly.holes.push_back(std::move(ring));
    }
    result.polygons.push_back(std::move(poly));
  }
}

/// The outcome of a traced layer: ok, unless its outline runs along pixels without depth for
/// more than max_unobserved_outline_fraction and reject_unobserved is set. The reason notes an
/// outline clipped by the image border or running along pixels without depth.
LayerResult judge_outline(LayerResult result, const OutlineCounts& counts, bool touches_image_border,
                          const LayerParams& layer_params) {
  LayerDiagnostics& diag = result.diagnostics;
  diag.unobserved_outline_fraction =
      counts.samples > 0 ? static_cast<double>(counts.unobserved) / static_cast<double>(counts.samples) : 0.0;
  diag.outline_along_invalid = diag.unobserved_outline_fraction > layer_params.max_unobserved_outline_fraction;
  std::ostringstream unobserved;
  if (diag.outline_along_invalid) {
    unobserved << "the layer's outline runs along pixels without depth for "
               << std::lround(100.0 * diag.unobserved_outline_fraction)
               << " % of its length; the layer may go on unseen there";
  }
  if (diag.outline_along_invalid && layer_params.reject_unobserved) {
    return fail(std::move(result), DetectionStatus::kNoLayer, unobserved.str());
  }
  result.status = DetectionStatus::kOk;
  if (touches_image_border) result.reason = "the layer touches the image border; its outline is clipped there";
  if (diag.outline_along_invalid) result.reason += (result.reason.empty() ? "" : "; ") + unobserved.str();
  return result;
}

}  // namespace

LayerResult extract_layer(const Frame& frame, const OrganizedCloud& cloud, const PlaneParams& plane_params,
                          const LayerParams& layer_params, const ContourParams& contour_params,
                          double min_component_area_m2, LayerTrace* trace) {
  LayerResult result;
  const auto t_start = Clock::now();
  const Intrinsics& K = frame.intrinsics;
  std::size_t usable = 0;
  const std::optional<std::string> bad_frame = frame_problem(K, cloud, plane_params, usable);
  result.diagnostics.valid_points = usable;
  if (bad_frame) return fail(result, DetectionStatus::kBadFrame, *bad_frame);

  // Stage 1: top plane.
  std::optional<Eigen::Vector3d> up_camera;  // the base's +z axis seen from the camera
  if (frame.T_base_camera) up_camera = frame.T_base_camera->linear().transpose() * Eigen::Vector3d::UnitZ();
  layer::TopPlane top = layer::find_top_plane(cloud, K, plane_params, usable, up_camera);
  result.diagnostics.plane_candidates = top.candidates;
  result.diagnostics.t_plane_ms = ms_since(t_start);
  if (top.status != DetectionStatus::kOk) return fail(result, top.status, top.reason);
  result.plane_camera = top.plane;
  result.diagnostics.plane_inliers = top.inliers;
  result.diagnostics.plane_sigma_m = top.sigma_m;

  // Stage 2: layer frame and band.
  const auto t_layer = Clock::now();
  result.T_camera_layer = layer::layer_frame(top.plane, top.centroid);
  const layer::BandTable band(top.noise, layer_params.passthrough_tolerance_m);
  result.diagnostics.passthrough_tolerance_m = band.max_m();

  // Stages 3-4: mask, border, components; the layer's points. 3b: a plane laid across two
  // levels, refitted on the highest piece.
  layer::LayerMask lm = layer::layer_mask(cloud, top.plane, band, plane_params);
  if (up_camera) {
    if (std::optional<layer::PieceLevel> level =
            layer::highest_piece_level(lm.mask, cloud, top.plane, *up_camera, plane_params)) {
      top.plane = level->plane;
      result.plane_camera = top.plane;
      result.T_camera_layer = layer::layer_frame(top.plane, level->centroid);
      result.diagnostics.level_refit_step_m = level->step_m;
      lm = layer::layer_mask(cloud, top.plane, band, plane_params);
    }
  }
  result.diagnostics.filled_dropouts = lm.filled_dropouts;
  result.diagnostics.touches_image_border = lm.touches_image_border;
  if (cv::countNonZero(lm.mask) == 0) {
    result.diagnostics.t_layer_ms = ms_since(t_layer);
    return fail(result, DetectionStatus::kNoLayer, "no layer pixels left after cleaning the plane's mask");
  }
  const layer::Components comps = layer::find_components(
      lm.mask, lm.border, cloud, top.plane, K, min_component_area_m2, layer_params.min_hole_area_px);
  result.diagnostics.components = comps.kept.size();
  result.diagnostics.dropped_components = comps.dropped;
  result.diagnostics.largest_cut_piece_m2 = comps.largest_cut_m2;
  result.diagnostics.border_points = static_cast<std::size_t>(cv::countNonZero(lm.border));
  const Eigen::Isometry3d T_layer_camera = result.T_camera_layer.inverse();
  collect_layer_points(lm.mask, cloud, T_layer_camera, plane_params, result);
  if (trace) record_mask(lm, *trace);
  result.diagnostics.t_layer_ms = ms_since(t_layer);
  if (comps.kept.empty()) {
    std::ostringstream s;
    s << "no layer component covers " << min_component_area_m2 << " m^2 (" << comps.dropped << " smaller ones dropped)";
    return fail(result, DetectionStatus::kNoLayer, s.str());
  }
  if (lm.touches_image_border && layer_params.reject_clipped)
    return fail(result, DetectionStatus::kNoLayer, "the layer touches the image border; its outline is clipped");

  // Stage 5: crust and polygons.
  const auto t_contour = Clock::now();
  const layer::PixelToLayer to_layer(K, top.plane, result.T_camera_layer);
  const OutlineContext ctx{lm.mask,      to_layer, cloud,        top.plane,      band, T_layer_camera,
                           plane_params, K.fx,     layer_params, contour_params, trace};
  OutlineCounts counts;
  trace_polygons(ctx, comps.kept, result, counts);
  result.diagnostics.t_contour_ms = ms_since(t_contour);
  if (result.polygons.empty()) return fail(result, DetectionStatus::kNoLayer, "no closed outline could be traced");
  return judge_outline(std::move(result), counts, lm.touches_image_border, layer_params);
}

}  // namespace palletd
