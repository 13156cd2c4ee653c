// detect(): the named stages of the pipeline, composed. Pure: values in, values out.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <utility>

#include "palletd/core/timing.hpp"
#include "palletd/detection/confidence.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/detection/picking.hpp"
#include "palletd/detection/recipe_check.hpp"

#include "fattened_edges.hpp"
#include "frame_problem.hpp"
#include "level_checks.hpp"
#include "level_geometry.hpp"
#include "poses.hpp"
#include "roi.hpp"
#include "top_layer.hpp"

namespace palletd {

const char* to_string(DetectionStatus status) {
  switch (status) {
    case DetectionStatus::kOk: return "ok";
    case DetectionStatus::kNoPlane: return "no_plane";
    case DetectionStatus::kNoLayer: return "no_layer";
    case DetectionStatus::kNoLayout: return "no_layout";
    case DetectionStatus::kBadFrame: return "bad_frame";
    case DetectionStatus::kEmpty: return "empty";
    case DetectionStatus::kSlipSheet: return "slip_sheet";
    case DetectionStatus::kRecipeMismatch: return "recipe_mismatch";
  }
  return "bad_frame";
}

const char* to_string(AmbiguityKind kind) {
  switch (kind) {
    case AmbiguityKind::kTiedLayouts: return "tied_layouts";
    case AmbiguityKind::kSearchBudget: return "search_budget";
    case AmbiguityKind::kUnexplainedArea: return "unexplained_area";
    case AmbiguityKind::kLevelCheck: return "level_check";
    case AmbiguityKind::kHeightOffLayers: return "height_off_layers";
  }
  return "level_check";
}

bool is_failure(DetectionStatus status) {
  return status != DetectionStatus::kOk && status != DetectionStatus::kEmpty && status != DetectionStatus::kSlipSheet;
}

namespace {

using Clock = DetectionEnd::Clock;

/// The most boxes one layer may hold: a 1.2 m x 1.2 m layer of 50 mm cartons. The stages after
/// the budgeted search (ranking, completion, the joint refinement) grow with the box count; a
/// format entered in the wrong unit (10 x 5 mm) or a layer far larger than a pallet would hold
/// thousands and take seconds.
constexpr double kMaxBoxesPerLayer = 600.0;

/// Why the layer cannot be laid out in bounded time with these formats; "" when it can.
std::string too_many_boxes(double layer_area_m2, double smallest_box_m2) {
  if (!(layer_area_m2 / smallest_box_m2 > kMaxBoxesPerLayer)) return {};
  return "the layer (" + std::to_string(layer_area_m2) + " m2) would hold more than " +
         std::to_string(static_cast<int>(kMaxBoxesPerLayer)) +
         " boxes of the smallest format: check the formats' sizes (millimetres) and the region of interest";
}

/// Why the layout search flagged its answer: a sentence for the operator per doubt that holds
/// (LayoutDoubts), joined, and their categories.
std::pair<std::string, std::vector<AmbiguityKind>> ambiguity_reason(const LayoutResult& layout) {
  const LayoutDoubts& d = layout.doubts;
  const std::string arrangement = "another arrangement of " + std::to_string(layout.runner_up.size()) +
                                  " boxes explains the outline and the seams nearly as well";
  const std::string budget = "the search ended at its budget before it could rule out other arrangements";
  const std::string unexplained = "part of the layer is not explained by the boxes found";
  std::string why;
  std::vector<AmbiguityKind> kinds;
  auto add = [&](const std::string& sentence, AmbiguityKind kind) {
    why += (why.empty() ? "" : "; ") + sentence;
    if (std::find(kinds.begin(), kinds.end(), kind) == kinds.end()) kinds.push_back(kind);
  };
  if (d.tied_layouts && !layout.runner_up.empty()) add(arrangement, AmbiguityKind::kTiedLayouts);
  if (d.undecided_formats)
    add("a box could as well be two boxes of another recipe format side by side, or two boxes one (the same "
        "footprint): no seam decides where they would differ, and a gap between cartons can be pressed shut",
        AmbiguityKind::kTiedLayouts);
  if (d.completion)
    add("boxes completed where the depth ends could stand otherwise, or none fits part of the layer there",
        AmbiguityKind::kTiedLayouts);
  if (d.uncovered) add(unexplained, AmbiguityKind::kUnexplainedArea);
  if (!why.empty() && layout.budget_exhausted) add(budget, AmbiguityKind::kSearchBudget);
  if (!why.empty()) return {why, kinds};
  // A flag without a recorded doubt: what the result shows.
  if (!layout.runner_up.empty()) return {arrangement, {AmbiguityKind::kTiedLayouts}};
  if (layout.budget_exhausted) return {budget, {AmbiguityKind::kSearchBudget}};
  return {unexplained, {AmbiguityKind::kUnexplainedArea}};
}

/// The frame's share of each box's score terms, then the calibrated confidences.
void score_boxes(const LayoutResult& layout, Detection& out) {
  std::vector<int> formats;
  for (const DetectedBox& b : out.boxes) formats.push_back(b.format);
  std::sort(formats.begin(), formats.end());
  const auto layout_formats = static_cast<int>(std::unique(formats.begin(), formats.end()) - formats.begin());
  for (DetectedBox& b : out.boxes) {
    b.score_terms.pitch_mm = 1e3 * layout.pixel_pitch_m;
    b.score_terms.rim_share = layout.rim_share;
    b.score_terms.layout_formats = layout_formats;
    b.score_terms.layout_ambiguous = out.ambiguous;
    b.score_terms.outline_unobserved = out.outline_unobserved;
    b.score = box_confidence(b.score_terms);
  }
  out.layout_confidence = layout_confidence(out);
}

/// Stage 8 on a layout found: the boxes, the recipe check, their confidences, the picks.
Detection boxes_of_layout(const Frame& frame, const std::vector<BoxFormat>& formats,
                          const DetectionParams& params, const DetectionWorkspace& workspace,
                          const LayoutResult& layout, Detection out, const DetectionEnd& end) {
  // Stage 8: poses in the camera and base frames, pick order, the layer's height.
  out.boxes =
      to_detected_boxes(layout.boxes, out.layer.T_camera_layer, frame.T_base_camera, params.pick_order);
  layer_height(layer_base_z_m(out.layer, frame.T_base_camera), formats, params.pallet, out);
  // Stage 8a: the cartons measured against the recipe; a layer of other cartons has no layout.
  out.recipe_check = check_recipe(out.boxes, formats, params.recipe_check, layout.pixel_pitch_m,
                                  params.layout.refine.max_oversize);
  // Tape across boxes whose sizes agree, on a layout already in doubt: the arrangement is in doubt.
  if (!out.recipe_check.agrees && !out.recipe_check.some_agree &&
      !(out.recipe_check.tape_only && out.ambiguous)) {
    out.boxes.clear();
    std::string reason = out.recipe_check.reason;
    return end(std::move(out), DetectionStatus::kRecipeMismatch, std::move(reason));
  }
  if (!out.recipe_check.agrees) {  // some formats fit, others not, or tape against a doubtful layout
    out.ambiguous = true;
    out.ambiguity_reason += (out.ambiguity_reason.empty() ? "" : "; ") + out.recipe_check.reason;
    out.ambiguity_kinds.push_back(AmbiguityKind::kLevelCheck);
  }
  score_boxes(layout, out);  // Stage 8b: each box's confidence, then the layout's.
  if (params.gripper) {      // Stage 8c: what the gripper can take now, and in which order.
    const auto t0 = Clock::now();
    const PickSurroundings surroundings{
        out.layer.T_camera_layer,
        obstacles_above_layer(frame, workspace.rays, out.layer.T_camera_layer,
                              1e-3 * params.gripper->obstacle_height_mm, params.roi ? &*params.roi : nullptr,
                              frame.T_base_camera),
        params.roi, frame.T_base_camera, frame.intrinsics};
    out.groups = plan_picks(surroundings, *params.gripper, out.boxes);
    out.timing_ms["picking"] = ms_since(t0);
  }
  // The layer's warnings (an outline along invalid depth) stay with a successful frame.
  std::string message = out.layer.reason;
  if (layout.completed_unseen > 0) {
    message += (message.empty() ? "" : "; ") + std::to_string(layout.completed_unseen) +
               " box(es) completed across the edge where the depth ends (partly_unseen)";
  }
  return end(std::move(out), DetectionStatus::kOk, std::move(message));
}

}  // namespace

std::string cloud_in_region(const Frame& frame, const DetectionParams& params, DetectionWorkspace& workspace) {
  if (!workspace.rays.matches(frame.intrinsics)) workspace.rays = RayTable(frame.intrinsics);
  to_organized_cloud(frame, workspace.rays, workspace.cloud);
  if (!params.roi) return {};
  return apply_region_of_interest(*params.roi, frame.T_base_camera, workspace.cloud);
}

LayerResult top_layer(const Frame& frame, const OrganizedCloud& cloud, const DetectionParams& params,
                      double smallest_box_m2) {
  const double min_piece_m2 = params.layer.min_component_box_fraction * smallest_box_m2;
  PlaneParams plane_params = params.plane;
  plane_params.min_plane_area_m2 = std::max(plane_params.min_plane_area_m2, min_piece_m2);
  LayerResult layer = extract_layer(frame, cloud, plane_params, params.layer, params.contour, min_piece_m2);
  return trim_fattened_edges(frame, std::move(layer), params.layer);  // stage 5b
}

Detection detect(const Frame& frame, const std::vector<BoxFormat>& formats, const DetectionParams& params,
                 RayTable* rays) {
  DetectionWorkspace workspace;
  if (rays != nullptr) workspace.rays = std::move(*rays);
  Detection out = detect(frame, formats, params, workspace);
  if (rays != nullptr) *rays = std::move(workspace.rays);
  return out;
}

Detection detect(const Frame& frame, const std::vector<BoxFormat>& formats, const DetectionParams& params,
                 DetectionWorkspace& workspace) {
  DetectionEnd end{frame, params, Clock::now()};
  Detection out;
  if (std::string problem = frame_problem(frame); !problem.empty())
    return end(std::move(out), DetectionStatus::kBadFrame, problem);
  end.readable = true;
  if (std::string problem = box_formats_problem(formats); !problem.empty())
    return end(std::move(out), DetectionStatus::kNoLayout, problem);

  // Stage 0: organized cloud into the caller's workspace (rays and cloud reused frame after frame).
  auto t0 = Clock::now();
  if (std::string problem = cloud_in_region(frame, params, workspace); !problem.empty()) {
    out.roi = params.roi;
    return end(std::move(out), DetectionStatus::kBadFrame, problem);
  }
  const double cloud_ms = ms_since(t0);

  // Stages 1-5: plane, layer, components, crust contour; 5b: fattened tops trimmed.
  const double smallest_box_m2 = level_detail::min_area_m2(formats);
  out = with_layer(top_layer(frame, workspace.cloud, params, smallest_box_m2), params);
  out.timing_ms["cloud"] = cloud_ms;
  if (out.layer.status != DetectionStatus::kOk) {
    const DetectionStatus status = out.layer.status;
    std::string reason = out.layer.reason;
    return end(std::move(out), status, std::move(reason));
  }
  return lay_out_layer(frame, formats, params, workspace, nullptr, std::move(out), end);
}

Detection with_layer(LayerResult layer, const DetectionParams& params) {
  Detection out;
  out.roi = params.roi;
  out.layer = std::move(layer);
  const LayerDiagnostics& diag = out.layer.diagnostics;
  out.timing_ms["plane"] = diag.t_plane_ms;
  out.timing_ms["layer"] = diag.t_layer_ms;
  out.timing_ms["contour"] = diag.t_contour_ms;
  out.timing_ms["edges"] = diag.t_edges_ms;
  out.plane_camera = out.layer.plane_camera;
  out.clipped_by_image_border = diag.touches_image_border;
  out.outline_unobserved = diag.outline_along_invalid;
  for (const auto& polygon : out.layer.polygons) out.layer_area_m2 += area(polygon);
  return out;
}

Detection DetectionEnd::operator()(Detection out, DetectionStatus status, std::string message) const {
  out.status = status;
  out.message = std::move(message);
  if (readable) {  // Stage 9: the cell's health, whatever became of the layer.
    const auto t_health = Clock::now();
    out.health =
        measure_frame_health(frame, params.roi ? &*params.roi : nullptr, out.layer, params.noise_model);
    out.timing_ms["health"] = ms_since(t_health);
  }
  out.timing_ms["total"] = ms_since(t_start);
  return out;
}

Detection lay_out_layer(const Frame& frame, const std::vector<BoxFormat>& formats,
                        const DetectionParams& params, DetectionWorkspace& workspace,
                        const LayerEvidence* evidence, Detection out, const DetectionEnd& end) {
  const OrganizedCloud& cloud = workspace.cloud;
  const double smallest_box_m2 = level_detail::min_area_m2(formats);
  const std::optional<double> layer_z_m = layer_base_z_m(out.layer, frame.T_base_camera);
  // An empty pallet or a slip sheet ends the frame without boxes (and without a layout's flags).
  auto without_boxes = [&](const LevelVerdict& verdict) {
    out.ambiguous = false;
    out.ambiguity_reason.clear();
    out.ambiguity_kinds.clear();
    out.status = verdict.status;  // layer_height() reads it
    layer_height(layer_z_m, formats, params.pallet, out);
    return end(std::move(out), verdict.status, verdict.message);
  };
  if (std::optional<LevelVerdict> empty = empty_level(frame, out.layer, formats, params)) return without_boxes(*empty);

  // Stages 6-7: layout search with seam evidence, refinement; then what the level is.
  if (std::string problem = too_many_boxes(out.layer_area_m2, smallest_box_m2); !problem.empty())
    return end(std::move(out), DetectionStatus::kNoLayout, problem);
  const auto t0 = Clock::now();
  const LayoutResult layout =
      evidence != nullptr
          ? solve_layout(frame, cloud, out.layer, *evidence, formats, params.layout, &workspace.search)
          : solve_layout(frame, cloud, out.layer, formats, params.layout, &workspace.search);
  out.timing_ms["layout"] = ms_since(t0);
  out.ambiguous = layout.ambiguous;
  out.budget_exhausted = layout.budget_exhausted;
  out.coverage = layout.coverage;
  out.interior_seams = layout.interior_seams;
  if (out.ambiguous) {
    auto [reason, kinds] = ambiguity_reason(layout);
    out.ambiguity_reason = std::move(reason);
    out.ambiguity_kinds.insert(out.ambiguity_kinds.end(), kinds.begin(), kinds.end());
  }
  const std::optional<double> above_deck_m = params.pallet.top_z_m && layer_z_m
                                                 ? std::optional<double>(*layer_z_m - *params.pallet.top_z_m)
                                                 : std::nullopt;
  if (std::optional<LevelVerdict> level =
          level_after_layout(cloud, layout, out.layer, formats, params.plane, params.layout.refine,
                             frame.T_base_camera, above_deck_m)) {
    if (level->status != DetectionStatus::kOk) return without_boxes(*level);
    out.ambiguous = true;
    out.ambiguity_reason += (out.ambiguity_reason.empty() ? "" : "; ") + level->message;
    out.ambiguity_kinds.push_back(AmbiguityKind::kLevelCheck);
  }
  if (layout.status != DetectionStatus::kOk) return end(std::move(out), layout.status, layout.reason);
  return boxes_of_layout(frame, formats, params, workspace, layout, std::move(out), end);
}

}  // namespace palletd
