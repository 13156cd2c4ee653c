// The configuration's field tables: one line per key. config/palletd.yaml documents each of them,
// and a test checks that the two agree.
#include "config_yaml.hpp"

namespace palletd::config_detail {

namespace {

const Table<PlaneParams>& plane_table() {
  static const Table<PlaneParams> t = {
      number("max_tilt_deg", &PlaneParams::max_tilt_deg, Range::closed(0.0, 89.0)),
      number("max_base_tilt_deg", &PlaneParams::max_base_tilt_deg, Range::closed(0.0, 45.0)),
      number("ransac_distance_m", &PlaneParams::ransac_distance_m, Range::positive(0.1)),
      integer("ransac_max_iterations", &PlaneParams::ransac_max_iterations, 1, 100000),
      number("min_plane_area_m2", &PlaneParams::min_plane_area_m2, Range::closed(0.0, 100.0)),
      integer("seed", &PlaneParams::seed, 0, 4294967295LL),
      integer("ransac_stride_px", &PlaneParams::ransac_stride_px, 0, 64),
      integer("max_planes", &PlaneParams::max_planes, 1, 50),
      number("min_depth_m", &PlaneParams::min_depth_m, Range::closed(0.0, 100.0)),
      number("max_depth_m", &PlaneParams::max_depth_m, Range::positive(100.0)),
  };
  return t;
}

const Table<LayerParams>& layer_table() {
  static const Table<LayerParams> t = {
      number("passthrough_tolerance_m", &LayerParams::passthrough_tolerance_m, Range::closed(0.0, 0.2)),
      number("min_component_box_fraction", &LayerParams::min_component_box_fraction, Range::closed(0.0, 1.0)),
      integer("min_hole_area_px", &LayerParams::min_hole_area_px, 0, 1000000),
      flag("reject_clipped", &LayerParams::reject_clipped),
      number("fattened_edge_min_px", &LayerParams::fattened_edge_min_px, Range::closed(0.0, 20.0)),
      number("fattened_edge_max_px", &LayerParams::fattened_edge_max_px, Range::closed(0.0, 20.0)),
  };
  return t;
}

const Table<ContourParams>& contour_table() {
  static const Table<ContourParams> t = {
      number("d_max_m", &ContourParams::d_max_m, Range::closed(0.0, 1.0)),
      number("simplify_tolerance_m", &ContourParams::simplify_tolerance_m, Range::closed(0.0, 0.1)),
      number("snap_angle_deg", &ContourParams::snap_angle_deg, Range::closed(0.0, 45.0)),
      number("merge_angle_deg", &ContourParams::merge_angle_deg, Range::closed(0.0, 90.0)),
  };
  return t;
}

const Table<LayoutParams>& layout_table() {
  using L = LayoutParams;
  using S = LayoutSearchParams;
  static const Table<LayoutParams> t = {
      within(&L::search, choice("search", &S::mode,
                                {{"best_first", SearchMode::kBestFirst},
                                 {"product", SearchMode::kBestFirst},
                                 {"paper", SearchMode::kPaper}})),
      within(&L::search, number("a_min_fraction", &S::a_min_fraction, Range::closed(0.0, 1.0))),
      within(&L::search, number("a_max_fraction", &S::a_max_fraction, Range::closed(0.0, 1.0))),
      within(&L::search,
             number("outline_tolerance_pitches", &S::outline_tolerance_pitches, Range::closed(0.0, 5.0))),
      within(&L::search, number("time_budget_ms", &S::time_budget_ms, Range::positive(60000.0))),
      within(&L::search, integer("search_expansions", &S::search_expansions, 1, 1000000000LL)),
      within(&L::search, number("ambiguity_margin", &S::ambiguity_margin, Range::closed(0.0, 1.0))),
      within(&L::search, number("corner_angle_tol_deg", &S::corner_angle_tol_deg, Range::closed(0.0, 45.0))),
      within(&L::search, number("line_merge_tol_m", &S::line_merge_tol_m, Range::closed(0.0, 0.1))),
      within(&L::seams, number("seam_weight", &SeamParams::weight, Range::closed(0.0, 1000.0))),
      within(&L::seams,
             number("missing_seam_weight", &SeamParams::missing_weight, Range::closed(0.0, 1000.0))),
      within(&L::seams, number("seam_margin_m", &SeamParams::margin_m, Range::closed(0.0, 0.1))),
      within(&L::seams, number("seam_cell_m", &SeamParams::cell_m, Range::closed(0.0, 0.05))),
      within(&L::seams, number("seam_depth_step_m", &SeamParams::depth_step_m, Range::closed(0.0, 0.1))),
      within(&L::seams, number("seam_depth_noise_k", &SeamParams::depth_noise_k, Range::closed(0.0, 20.0))),
      within(&L::seams,
             number("seam_intensity_weight", &SeamParams::intensity_weight, Range::closed(0.0, 1.0))),
      within(&L::seams,
             number("seam_intensity_noise_k", &SeamParams::intensity_noise_k, Range::closed(0.0, 20.0))),
      within(&L::search, integer("max_nodes", &S::max_nodes, 1, 1000000000LL)),
      within(&L::search, integer("paper_max_hypotheses", &S::paper_max_hypotheses, 1, 1000000000LL)),
      within(&L::search, choice("area_method", &S::area_method,
                                {{"grid_sat", AreaMethod::kGridSat},
                                 {"raster", AreaMethod::kRaster},
                                 {"clip", AreaMethod::kClip}})),
      within(&L::search, number("area_raster_cell_m", &S::area_raster_cell_m, Range::positive(0.1))),
      within(&L::search, number("min_coverage", &S::min_coverage, Range::closed(0.0, 1.0))),
      within(&L::refine, flag("refine", &RefineParams::enabled)),
      within(&L::refine,
             number("refine_size_tolerance_m", &RefineParams::size_tolerance_m, Range::closed(0.0, 0.1))),
      within(&L::refine, number("refine_max_oversize", &RefineParams::max_oversize, Range::closed(0.0, 0.2))),
      within(&L::refine,
             number("refine_yaw_sigma_deg", &RefineParams::yaw_sigma_deg, Range::closed(0.0, 10.0))),
      within(&L::refine, number("refine_max_position_sigma_mm", &RefineParams::max_position_sigma_mm,
                                Range::closed(0.0, 1000.0))),
      within(&L::refine, number("refine_max_position_sigma_px", &RefineParams::max_position_sigma_px,
                                Range::closed(0.0, 100.0))),
      within(&L::refine,
             number("refine_max_yaw_sigma_deg", &RefineParams::max_yaw_sigma_deg, Range::closed(0.0, 45.0))),
      within(&L::completion,
             number("unseen_min_fraction", &CompletionParams::unseen_min_fraction, Range::closed(0.0, 1.0))),
      within(&L::completion, number("uncovered_flag_fraction", &CompletionParams::uncovered_flag_fraction,
                                    Range::closed(0.0, 10.0))),
  };
  return t;
}

const Table<RecipeCheckParams>& recipe_check_table() {
  static const Table<RecipeCheckParams> t = {
      flag("enabled", &RecipeCheckParams::enabled),
      number("undersize_tolerance_mm", &RecipeCheckParams::undersize_tolerance_mm, Range::closed(0.0, 200.0)),
      number("undersize_pitches", &RecipeCheckParams::undersize_pitches, Range::closed(0.0, 10.0)),
      number("oversize_tolerance_mm", &RecipeCheckParams::oversize_tolerance_mm, Range::closed(0.0, 200.0)),
      number("oversize_pitches", &RecipeCheckParams::oversize_pitches, Range::closed(0.0, 10.0)),
      integer("min_boxes_measured", &RecipeCheckParams::min_boxes_measured, 1, 1000),
      integer("min_boxes_tape_across", &RecipeCheckParams::min_boxes_tape_across, 0, 1000),
  };
  return t;
}

}  // namespace

const Table<DetectionParams>& detection_table() {
  static const Table<DetectionParams> t = {
      {"roi",
       [](const Context& ctx, const YAML::Node& node, const std::string& path, DetectionParams& out) {
         out.roi = read_roi(ctx, node, path);
       },
       [](const DetectionParams& a, const DetectionParams& b, const std::string& path, std::vector<std::string>& diffs) {
         const bool same = a.roi == b.roi;
         if (!same) diffs.push_back(path);
       },
       list_leaf<DetectionParams>},
      section("plane", &DetectionParams::plane, plane_table),
      section("layer", &DetectionParams::layer, layer_table),
      section("contour", &DetectionParams::contour, contour_table),
      section("layout", &DetectionParams::layout, layout_table),
      section("recipe_check", &DetectionParams::recipe_check, recipe_check_table),
      choice("pick_order", &DetectionParams::pick_order,
             {{"far_corner_first", PickOrder::kFarCornerFirst},
              {"row_major", PickOrder::kRowMajor},
              {"nearest_first", PickOrder::kNearestFirst}}),
  };
  return t;
}

const Table<PalletParams>& pallet_table() {
  static const Table<PalletParams> t = {
      optional_number("top_z_m", &PalletParams::top_z_m, Range::closed(-10.0, 10.0)),
      number("height_tolerance", &PalletParams::height_tolerance, Range::closed(0.01, 0.5)),
  };
  return t;
}

const Table<PipelineConfig>& pipeline_table() {
  static const Table<PipelineConfig> t = {
      number("detection_timeout_ms", &PipelineConfig::detection_timeout_ms, Range::positive(600000.0)),
      integer("default_recipe", &PipelineConfig::default_recipe, 0, 65535),
  };
  return t;
}

const Table<LoggingConfig>& logging_table() {
  static const Table<LoggingConfig> t = {
      text("level", &LoggingConfig::level, {"trace", "debug", "info", "warn", "error"}),
  };
  return t;
}

const Table<RecordingConfig>& recording_table() {
  static const Table<RecordingConfig> t = {
      flag("enabled", &RecordingConfig::enabled),
      file_path("directory", &RecordingConfig::directory),
      integer("max_bytes", &RecordingConfig::max_bytes, 1LL << 20, 1LL << 50),
      flag("every_trigger", &RecordingConfig::every_trigger),
      flag("overlays", &RecordingConfig::overlays),
  };
  return t;
}

namespace {

const Table<DepthNoiseModel>& noise_model_table() {
  static const Table<DepthNoiseModel> t = {
      number("sigma_mm_at_1m", &DepthNoiseModel::sigma_mm_at_1m, Range::closed(0.0, 100.0)),
      number("exponent", &DepthNoiseModel::exponent, Range::closed(0.0, 4.0)),
  };
  return t;
}

}  // namespace

const Table<HealthConfig>& health_table() {
  static const Table<HealthConfig> t = {
      integer("window_frames", &HealthConfig::window_frames, 1, 10000),
      number("max_invalid_fraction", &HealthConfig::max_invalid_fraction, Range::closed(0.0, 1.0)),
      number("max_flying_fraction", &HealthConfig::max_flying_fraction, Range::closed(0.0, 1.0)),
      number("max_saturated_fraction", &HealthConfig::max_saturated_fraction, Range::closed(0.0, 1.0)),
      number("max_noise_ratio", &HealthConfig::max_noise_ratio, Range::positive(100.0)),
      section("noise_model", &HealthConfig::noise_model, noise_model_table),
      file_path("drift_reference", &HealthConfig::drift_reference),
      number("max_drift_mm", &HealthConfig::max_drift_mm, Range::positive(10000.0)),
      number("max_drift_deg", &HealthConfig::max_drift_deg, Range::positive(180.0)),
  };
  return t;
}

const Table<PickCheckParams>& check_table() {
  static const Table<PickCheckParams> t = {
      number("tolerance_mm", &PickCheckParams::tolerance_mm, Range::positive(1000.0)),
      number("tolerance_deg", &PickCheckParams::tolerance_deg, Range::positive(90.0)),
  };
  return t;
}

}  // namespace palletd::config_detail
