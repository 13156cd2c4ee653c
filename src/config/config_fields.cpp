// The configuration's field tables: one line per key. config/palletd.yaml documents each of them,
// and a test checks that the two agree.
#include "config_yaml.hpp"

namespace palletd::config_detail {

namespace {

const Table<ReplayOptions>& replay_table() {
  static const Table<ReplayOptions> t = {
      file_path("directory", &ReplayOptions::directory),
      flag("loop", &ReplayOptions::loop),
      number("rate_hz", &ReplayOptions::rate_hz, Range::closed(0.0, 1000.0)),
  };
  return t;
}

const Table<AravisOptions>& aravis_table() {
  static const Table<AravisOptions> t = {
      text("address", &AravisOptions::address),
      text("serial", &AravisOptions::serial),
      text("user_id", &AravisOptions::user_id),
      text("pixel_format", &AravisOptions::pixel_format, {"Coord3D_C16", "Coord3D_ABC32f", "Mono16"}),
      number("mono16_scale_m", &AravisOptions::mono16_scale_m, Range::positive(1.0)),
      integer("packet_size", &AravisOptions::packet_size, 0, 65535),
      flag("packet_resend", &AravisOptions::packet_resend),
      integer("buffer_count", &AravisOptions::buffer_count, 1, 256),
      flag("software_trigger", &AravisOptions::software_trigger),
  };
  return t;
}

const Table<OpenNI2Options>& openni2_table() {
  static const Table<OpenNI2Options> t = {
      text("uri", &OpenNI2Options::uri),
      integer("width", &OpenNI2Options::width, 1, 10000),
      integer("height", &OpenNI2Options::height, 1, 10000),
      integer("fps", &OpenNI2Options::fps, 1, 1000),
      number("depth_unit_m", &OpenNI2Options::depth_unit_m, Range::positive(1.0)),
      flag("ir_as_intensity", &OpenNI2Options::ir_as_intensity),
      flag("loop", &OpenNI2Options::loop),
  };
  return t;
}

Field<CameraConfig> intrinsics_field() {
  return {"intrinsics",
          [](const Context& ctx, const YAML::Node& node, const std::string& path, CameraConfig& out) {
            out.intrinsics_override = read_intrinsics(ctx, node, path);
          },
          [](const CameraConfig& a, const CameraConfig& b, const std::string& path, std::vector<std::string>& diffs) {
            const auto& x = a.intrinsics_override;
            const auto& y = b.intrinsics_override;
            const bool same = x.has_value() == y.has_value() &&
                              (!x || (x->width == y->width && x->height == y->height && x->fx == y->fx &&
                                      x->fy == y->fy && x->cx == y->cx && x->cy == y->cy &&
                                      x->distortion == y->distortion));
            if (!same) diffs.push_back(path);
          },
          list_leaf<CameraConfig>};
}

const Table<PlaneParams>& plane_table() {
  static const Table<PlaneParams> t = {
      number("max_tilt_deg", &PlaneParams::max_tilt_deg, Range::closed(0.0, 89.0)),
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
      within(&L::search, number("outline_tolerance_pitches", &S::outline_tolerance_pitches, Range::closed(0.0, 5.0))),
      within(&L::search, number("time_budget_ms", &S::time_budget_ms, Range::positive(60000.0))),
      within(&L::search, integer("search_expansions", &S::search_expansions, 1, 1000000000LL)),
      within(&L::search, number("ambiguity_margin", &S::ambiguity_margin, Range::closed(0.0, 1.0))),
      within(&L::search, number("corner_angle_tol_deg", &S::corner_angle_tol_deg, Range::closed(0.0, 45.0))),
      within(&L::search, number("line_merge_tol_m", &S::line_merge_tol_m, Range::closed(0.0, 0.1))),
      within(&L::seams, number("seam_weight", &SeamParams::weight, Range::closed(0.0, 1000.0))),
      within(&L::seams, number("missing_seam_weight", &SeamParams::missing_weight, Range::closed(0.0, 1000.0))),
      within(&L::seams, number("seam_margin_m", &SeamParams::margin_m, Range::closed(0.0, 0.1))),
      within(&L::seams, number("seam_cell_m", &SeamParams::cell_m, Range::closed(0.0, 0.05))),
      within(&L::seams, number("seam_depth_step_m", &SeamParams::depth_step_m, Range::closed(0.0, 0.1))),
      within(&L::seams, number("seam_depth_noise_k", &SeamParams::depth_noise_k, Range::closed(0.0, 20.0))),
      within(&L::seams, number("seam_intensity_weight", &SeamParams::intensity_weight, Range::closed(0.0, 1.0))),
      within(&L::seams, number("seam_intensity_noise_k", &SeamParams::intensity_noise_k, Range::closed(0.0, 20.0))),
      within(&L::search, integer("max_nodes", &S::max_nodes, 1, 1000000000LL)),
      within(&L::search, integer("paper_max_hypotheses", &S::paper_max_hypotheses, 1, 1000000000LL)),
      within(&L::search, choice("area_method", &S::area_method,
                                {{"grid_sat", AreaMethod::kGridSat}, {"raster", AreaMethod::kRaster},
                                 {"clip", AreaMethod::kClip}})),
      within(&L::search, number("area_raster_cell_m", &S::area_raster_cell_m, Range::positive(0.1))),
      within(&L::search, number("min_coverage", &S::min_coverage, Range::closed(0.0, 1.0))),
      within(&L::refine, flag("refine", &RefineParams::enabled)),
      within(&L::refine, number("refine_size_tolerance_m", &RefineParams::size_tolerance_m, Range::closed(0.0, 0.1))),
      within(&L::refine, number("refine_yaw_sigma_deg", &RefineParams::yaw_sigma_deg, Range::closed(0.0, 10.0))),
      within(&L::completion,
             number("unseen_min_fraction", &CompletionParams::unseen_min_fraction, Range::closed(0.0, 1.0))),
      within(&L::completion,
             number("uncovered_flag_fraction", &CompletionParams::uncovered_flag_fraction, Range::closed(0.0, 10.0))),
  };
  return t;
}

}  // namespace

const Table<CameraConfig>& camera_table() {
  static const Table<CameraConfig> t = {
      text("driver", &CameraConfig::driver, {"replay", "aravis", "openni2"}),
      number("frame_timeout_ms", &CameraConfig::frame_timeout_ms, Range::positive(600000.0)),
      number("reconnect_min_s", &CameraConfig::reconnect_min_s, Range::positive(3600.0)),
      number("reconnect_max_s", &CameraConfig::reconnect_max_s, Range::positive(3600.0)),
      number("control_timeout_ms", &CameraConfig::control_timeout_ms, Range::positive(60000.0)),
      intrinsics_field(),
      section("replay", &CameraConfig::replay, replay_table),
      section("aravis", &CameraConfig::aravis, aravis_table),
      section("openni2", &CameraConfig::openni2, openni2_table),
  };
  return t;
}

const Table<DetectionParams>& detection_table() {
  static const Table<DetectionParams> t = {
      section("plane", &DetectionParams::plane, plane_table),
      section("layer", &DetectionParams::layer, layer_table),
      section("contour", &DetectionParams::contour, contour_table),
      section("layout", &DetectionParams::layout, layout_table),
      choice("pick_order", &DetectionParams::pick_order,
             {{"far_corner_first", PickOrder::kFarCornerFirst},
              {"row_major", PickOrder::kRowMajor},
              {"nearest_first", PickOrder::kNearestFirst}}),
  };
  return t;
}

const Table<modbus::ServerOptions>& modbus_table() {
  using M = modbus::ServerOptions;
  const auto address = [](const std::string& a) { return check_address(a, false); };
  const auto block = [](const std::string& a) { return check_address(a, true); };
  static const Table<M> t = {
      {"bind_address",
       [address](const Context& ctx, const YAML::Node& node, const std::string& path, M& out) {
         std::string v = read_string(ctx, node, path);
         if (auto e = address(v); !e.empty()) fail(ctx, node, path, e);
         out.bind_address = std::move(v);
       },
       compare_member(&M::bind_address), list_leaf<M>},
      integer("port", &M::port, 1, 65535),
      integer("unit_id", &M::unit_id, 0, 255),
      within(&M::handshake, word_order_flag("low_word_first", &modbus::HandshakeOptions::word_order)),
      texts("allow", &M::allow, block),
      texts("read_only", &M::read_only, block),
      integer("max_connections", &M::max_connections, 1, 1024),
      number("idle_timeout_s", &M::idle_timeout_s, Range::closed(0.0, 86400.0)),
      within(&M::handshake, number("plc_heartbeat_timeout_s", &modbus::HandshakeOptions::plc_heartbeat_timeout_s,
                                   Range::closed(0.0, 3600.0))),
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

const Table<WebConfig>& web_table() {
  const auto address = [](const std::string& a) { return check_address(a, false); };
  static const Table<WebConfig> t = {
      flag("enabled", &WebConfig::enabled),
      within(&WebConfig::server,
             Field<WebOptions>{"bind_address",
                               [address](const Context& ctx, const YAML::Node& node, const std::string& path,
                                         WebOptions& out) {
                                 std::string v = read_string(ctx, node, path);
                                 if (auto e = address(v); !e.empty()) fail(ctx, node, path, e);
                                 out.bind_address = std::move(v);
                               },
                               compare_member(&WebOptions::bind_address), list_leaf<WebOptions>}),
      within(&WebConfig::server, integer("port", &WebOptions::port, 1, 65535)),
      within(&WebConfig::server, flag("allow_snapshot_post", &WebOptions::allow_snapshot_post)),
      within(&WebConfig::server, integer("refresh_ms", &WebOptions::refresh_ms, 100, 60000)),
      within(&WebConfig::server, texts("allowed_hosts", &WebOptions::allowed_hosts)),
  };
  return t;
}

}  // namespace palletd::config_detail
