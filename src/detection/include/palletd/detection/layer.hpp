// palletd detection, first half (paper Section III): top plane, layer points, border,
// components and holes, crust contour. Every stage is a function of values in and values out.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/status.hpp"

namespace palletd {

/// Top plane search (stage 1).
struct PlaneParams {
  double max_tilt_deg = 35.0;          ///< planes whose normal is further than this from the view axis are ignored
  /// With the frame's camera_to_base: layers of cartons are level, so only planes whose normal
  /// lies within this of the base +z axis count (max_tilt_deg then does not apply) [deg].
  double max_base_tilt_deg = 5.0;
  double ransac_distance_m = 0.008;    ///< smallest RANSAC inlier band [m] (wider when the measured depth noise needs it)
  int ransac_max_iterations = 200;
  double min_plane_area_m2 = 0.02;     ///< a plane smaller than this is no layer [m^2]
  std::uint32_t seed = 12345;          ///< RANSAC sampling seed (same frame and seed, same result)
  int ransac_stride_px = 0;            ///< RANSAC on every n-th pixel in u and v (0: ~2500 points); refit uses all
  int max_planes = 6;                  ///< at most this many RANSAC rounds while looking for the top
  double min_depth_m = 0.1;            ///< depths outside [min, max] are treated as invalid [m]
  double max_depth_m = 15.0;           ///< [m]
};

/// Layer points, mask, components (stages 2-4).
struct LayerParams {
  double passthrough_tolerance_m = 0.0;  ///< |z| band around the plane [m]; 0 = 3 sigma + 4 mm of the measured noise at each depth
  double min_component_box_fraction = 0.5;  ///< components smaller than this share of the smallest box are dropped
  int min_hole_area_px = 8;  ///< holes whose pixel contour encloses at most this area [px^2] are dropouts
  bool reject_clipped = false;  ///< true: a layer touching the image border ends in no_layer
  /// Outline share beyond which the layer counts as not fully observed: outline samples whose
  /// outside neighbour has no depth and no depth is measured further out within
  /// unobserved_gap_m (beyond the sensor's range, too dark), so the layer may go on there unseen.
  double max_unobserved_outline_fraction = 0.05;
  /// A strip without depth narrower than this beside the outline (a projector shadow, dropouts
  /// at the edge) still shows where the layer ends when a surface is seen beyond it [m].
  double unobserved_gap_m = 0.05;
  bool reject_unobserved = false;  ///< true: a layer not fully observed ends in no_layer
  /// A stereo camera fattens the tops (its matching window straddles their edges): where the
  /// depth's outline lies more than this many pixel pitches outside the edges the intensity image
  /// shows, the outline is moved in onto them and the layer points beyond are dropped. 0: never.
  double fattened_edge_min_px = 1.0;
  /// Offsets beyond this many pixel pitches are no matching window's: the outline is left alone.
  double fattened_edge_max_px = 4.0;
};

/// Crust contour and polygon simplification (stage 5).
struct ContourParams {
  double d_max_m = 0.0;                ///< Delaunay edges longer than this are pruned [m]; 0 = from pixel pitch
  double simplify_tolerance_m = 0.006; ///< ring simplification tolerance [m]
  double snap_angle_deg = 4.0;  ///< edges this close to the ring's dominant grid are snapped onto it
  double merge_angle_deg = 12.0;  ///< consecutive edges closer than this in direction are merged
};

/// Per-stage diagnostics of the layer extraction.
struct LayerDiagnostics {
  std::size_t valid_points = 0;
  std::size_t plane_inliers = 0;
  std::size_t layer_points = 0;
  std::size_t border_points = 0;
  std::size_t filled_dropouts = 0;     ///< invalid pixels inside the layer taken as layer
  std::size_t components = 0;          ///< components kept
  std::size_t dropped_components = 0;  ///< components smaller than the minimum area
  /// The largest of the dropped components that reach the image's edge [m^2] (0: none): what
  /// the image shows of a carton it cuts off.
  double largest_cut_piece_m2 = 0.0;
  std::size_t plane_candidates = 0;    ///< large enough planes seen while looking for the top
  double plane_sigma_m = 0.0;          ///< robust sigma (1.4826 MAD) of the residuals near the plane [m]
  /// How far the highest piece of the plane's first band stood above its lowest piece when the
  /// plane was refitted on the highest (a plane laid across two levels; 0: not refitted) [m].
  double level_refit_step_m = 0.0;
  double passthrough_tolerance_m = 0.0;  ///< widest |z| band used [m] (the band follows the depth)
  double d_max_m = 0.0;                ///< crust pruning length used [m]
  bool touches_image_border = false;
  /// Share of the outline (edge samples between a border pixel and its off-layer 4-neighbour)
  /// whose outside runs along invalid pixels (no depth within LayerParams::unobserved_gap_m).
  double unobserved_outline_fraction = 0.0;
  /// unobserved_outline_fraction > LayerParams::max_unobserved_outline_fraction: the outline
  /// there is where the depth ends, not where the layer ends (LayerResult::reason says so).
  bool outline_along_invalid = false;
  /// How far inside the depth's outline the intensity image shows the layer's edges [m] (median
  /// over the outline; 0 without an estimate), how far the outline was moved in for it [m], and
  /// how far it was then moved towards the camera for the sides that face it and are fattened
  /// less [m] (stage 5b, fattened_edges.hpp).
  double edge_offset_m = 0.0;
  double edges_moved_in_m = 0.0;
  double edges_shifted_m = 0.0;
  /// Where the sides' steps lie against the boxes' sides in this layer's frames, for sides that
  /// face the camera and sides that face away [m], as a pick check measured them (check_pick);
  /// unset until one has. after_pick() carries them on: later frames show fewer sides.
  std::optional<double> side_steps_facing_m, side_steps_away_m;
  double t_plane_ms = 0.0, t_layer_ms = 0.0, t_contour_ms = 0.0;
  double t_edges_ms = 0.0;  ///< stage 5b, the fattened tops trimmed (trim_fattened_edges)
};

/// Intermediate results kept for debug pictures (render_layer_debug_images in layer_debug.hpp).
struct LayerTrace {
  int width = 0, height = 0;
  std::vector<std::uint8_t> layer_mask;   ///< width*height, 1 = layer pixel after cleaning
  std::vector<std::int32_t> border_pixels;  ///< pixel indices of the border points
  /// Delaunay edges kept after pruning, layer frame [m].
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> crust_edges;
  std::vector<Ring2d> crust_rings;        ///< rings before simplification, layer frame [m]
};

/// Result of the first half of the pipeline.
struct LayerResult {
  DetectionStatus status = DetectionStatus::kNoPlane;
  std::string reason;                 ///< a sentence when status != ok
  Plane plane_camera;                 ///< top plane in the camera frame
  Eigen::Isometry3d T_camera_layer = Eigen::Isometry3d::Identity();  ///< layer -> camera
  std::vector<PolygonWithHoles> polygons;  ///< one per component, layer frame [m]
  std::vector<Eigen::Vector2f> points_2d;  ///< layer points in the layer frame [m]
  std::vector<std::int32_t> point_pixels;  ///< pixel index of each entry of points_2d
  LayerDiagnostics diagnostics;
};

/// The first half of the pipeline on one frame: top plane, layer points, border, components and
/// holes, crust contour, simplified polygons.
///
/// `cloud` must be the organized cloud of `frame` (same size); `frame` supplies the intrinsics
/// (viewing rays of pixels without depth). `min_component_area_m2`: components smaller than
/// this are dropped (callers pass min_component_box_fraction x the smallest box area).
/// When `trace` is given it receives the intermediate results for debug pictures.
/// Never throws on bad input: the status says no_plane / no_layer / bad_frame with a reason.
LayerResult extract_layer(const Frame& frame, const OrganizedCloud& cloud,
                          const PlaneParams& plane_params, const LayerParams& layer_params,
                          const ContourParams& contour_params, double min_component_area_m2,
                          LayerTrace* trace = nullptr);

}  // namespace palletd
