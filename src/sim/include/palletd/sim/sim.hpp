// palletd sim: a scene simulator that renders what a depth camera above a pallet sees, with ground
// truth in the frame format of shared/spec/frames.md (docs/simulator.md describes the model).
//
// World ("pallet") frame: origin on the floor under the pallet centre, x along the pallet's long
// side, z up, metres. Everything is deterministic: the same options and seed give the same bytes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"
#include "palletd/core/truth.hpp"

namespace palletd::sim {

enum class PalletKind { kNone, kEur1200x800, kIndustrial1200x1000 };
enum class PatternFamily { kBlock, kInterlock, kBrick, kPinwheel, kChimney, kMixed };
/// How a depalletizer emptied the top layer (used when fill < 1).
enum class RemovalMode { kRows, kColumns, kCorner, kRandom, kHoles, kClusters };
enum class SensorKind { kTimeOfFlight, kStructuredLight, kActiveStereo };
/// What stands on the pallet and around it (docs/simulator.md, "Scene families").
/// kIsolated: a pallet with its layers alone on the floor; kCell: the same inside a cell
/// (cabinet, posts, conveyor, a second stack); kStepped: one to three boxes left on a full level;
/// kEmpty: the bare pallet; kSlipSheet: a cardboard sheet covering a full level.
enum class SceneFamily { kIsolated, kCell, kStepped, kEmpty, kSlipSheet };

/// A box format: top face long x short side and height [m]; name like "315x232".
struct BoxFormatSpec {
  std::string name;
  double long_m = 0.0;
  double short_m = 0.0;
  double height_m = 0.0;
};

/// "600x400", "315x232x200" (height in mm optional) -> format; default heights per size.
Expected<BoxFormatSpec> parse_format(const std::string& text);

/// A rectangular patch on a box's top face (tape strip, label), box-local [m].
struct SurfacePatch {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector2d half_size = Eigen::Vector2d::Zero();
  double reflectance = 0.5;
};

/// One cuboid of the scene (a box, or a part of the pallet), world frame.
struct SimBox {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< footprint centre [m]
  double yaw_rad = 0.0;       ///< direction of the long side from the x axis [rad]
  double long_m = 0.0;        ///< as built [m]
  double short_m = 0.0;       ///< as built [m]
  double bottom_z_m = 0.0;
  double top_z_m = 0.0;       ///< height of the top face's rim [m]
  double bulge_m = 0.0;       ///< top face centre above (+) or below (-) the rim [m]
  double bevel_m = 0.0;       ///< radius of the rounded top edge [m]
  double corner_radius_m = 0.0;  ///< radius of the rounded vertical corners, in plan [m]
  double reflectance = 0.5;
  std::vector<SurfacePatch> patches;
  std::string format;         ///< format name; empty for pallet parts
  int format_index = -1;      ///< index into Scene::recipe; -1 for pallet parts
};

/// What to build. Ranges are drawn uniformly per scene (or per box) from the seed.
struct ScenarioOptions {
  PalletKind pallet = PalletKind::kEur1200x800;
  PatternFamily pattern = PatternFamily::kBlock;
  /// Formats of the layer: the first is used; Mixed uses the first two. Empty: a default per pattern.
  std::vector<BoxFormatSpec> formats;
  /// Extra recipe formats that are not in the layer (the detector is told about them too).
  std::vector<BoxFormatSpec> extra_recipe;
  int lower_layers_min = 1, lower_layers_max = 2;
  double fill = 1.0;  ///< share of the top layer's boxes that remain, (0, 1]; at least one box
  RemovalMode removal = RemovalMode::kRows;
  // Real boxes.
  double size_tolerance_m = 0.002;  ///< per side, uniform +-
  double jitter_m = 0.004;          ///< placement, uniform +-
  double jitter_deg = 1.5;          ///< yaw, uniform +-
  double gap_max_m = 0.015;         ///< gap between neighbours drawn in [0, gap_max]
  double bulge_max_m = 0.004;       ///< top face bulge (+) or sag (-) drawn in +-bulge_max
  double bevel_m = 0.003;           ///< rounded top edge radius
  double height_tolerance_m = 0.001;
  double layer_offset_max_m = 0.02; ///< whole layer shift on the pallet
  double tape_probability = 0.7;
  double label_probability = 0.5;
  double oversize_max = 0.0;  ///< built boxes exceed nominal by a share drawn in [max/5, max] per layer
  double corner_radius_min_m = 0.0, corner_radius_max_m = 0.0;  ///< vertical corners, drawn per box
  // Scene family and cell.
  SceneFamily scene = SceneFamily::kIsolated;
  bool cell = false;             ///< cell surroundings for any family (kCell implies them)
  bool solid_deck = false;       ///< the pallet's deck as one slab (sets made before issue 19)
  /// Pallet stops: posts beside the pallet, inside the region of interest and higher than the
  /// load, that a gripper must keep clear of (docs/simulator.md, "Scene families").
  bool pallet_stops = false;
  int stepped_min = 1, stepped_max = 3;  ///< boxes left on top in a stepped scene
  double cell_tilt_min_deg = 3.0, cell_tilt_max_deg = 20.0;  ///< camera tilt in a cell
  // Camera.
  double height_min_m = 1.2, height_max_m = 3.0;  ///< camera above the top layer
  double tilt_max_deg = 30.0;
  bool keep_layer_in_view = true;
  double view_margin = 0.03;  ///< share of the image size kept free at the border
};

/// A built scene: the boxes, the pallet, the camera.
struct Scene {
  PalletKind pallet = PalletKind::kEur1200x800;
  double pallet_long_m = 1.2, pallet_short_m = 0.8;  ///< area the layer must fit [m]
  double floor_reflectance = 0.25;
  std::vector<SimBox> boxes;            ///< pallet parts, lower layers and the top layer
  std::vector<std::size_t> top_layer;   ///< indices into boxes of the top layer's boxes
  double top_z_m = 0.0;                 ///< nominal top layer plane height [m] (deck or sheet when no boxes)
  std::vector<std::size_t> surroundings;  ///< indices of the cell's parts; the first is the cabinet
  std::vector<std::size_t> stops;         ///< indices of pallet stops (ScenarioOptions::pallet_stops)
  SceneFamily family = SceneFamily::kIsolated;
  std::string expect = "boxes";         ///< what a detector must answer: boxes, empty, slip_sheet
  bool has_roi = false;                 ///< a suggested region of interest exists (cell scenes)
  Eigen::Vector3d roi_min_m = Eigen::Vector3d::Zero(), roi_max_m = Eigen::Vector3d::Zero();  ///< world
  std::vector<BoxFormatSpec> recipe;    ///< formats of the cell's recipe
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  std::string description;              ///< e.g. "pinwheel 315x232 fill 0.60 rows"
};

/// Depth + intensity sensor model. profile_by_name() gives the built-in ones.
struct SensorProfile {
  std::string name;
  std::string camera_id;  ///< written into the frame, "model-serial"
  SensorKind kind = SensorKind::kTimeOfFlight;
  Intrinsics intrinsics;
  double depth_scale_m = 0.001;
  int intensity_bits = 16;
  double min_range_m = 0.3, max_range_m = 6.0;
  int supersampling = 3;  ///< n x n rays per pixel (mixed pixels at depth edges)
  // ToF: sigma along the ray = tof_sigma_2m_m * (r / 2 m) / sqrt(rho cos / reference_reflectance)
  double tof_sigma_2m_m = 0.005;
  double reference_reflectance = 0.5;
  // Structured light (Nguyen et al. 2012): sigma_z = a + b (z - z0)^2, then disparity quantisation.
  double sl_sigma_a_m = 0.0012, sl_sigma_b_per_m = 0.0019, sl_z0_m = 0.4;
  double sl_baseline_m = 0.075;          ///< camera -> projector along camera x [m]
  double sl_disparity_step_px = 0.125;   ///< sub-pixel disparity resolution [px]
  // Active stereo: sigma_z = z^2 sigma_d / (fx b) with b = sl_baseline_m (second imager along x);
  // each pixel takes the depth of a nearer neighbour within 1..stereo_fattening_px (matching window).
  double stereo_sigma_px = 0.016;
  int stereo_fattening_px = 2;
  // Both.
  double invalid_min = 0.01, invalid_max = 0.03;  ///< random dropout share, drawn per frame
  double min_amplitude_rel = 0.03;  ///< amplitude below this share of the reference -> invalid
  double multipath_bias_m = 0.0;    ///< extra range at the foot of vertical faces [m]
  double multipath_range_m = 0.05;  ///< how far from the face the bias reaches [m]
  double intensity_ref = 0.01;      ///< share of full scale the reference surface gives at 2 m
  double intensity_noise_rel = 0.02;
};

/// Built-in profiles: "o3d303", "o3d303-small", "blaze101", "helios2", "xtion", "d435" (what
/// `--profile all` draws from); profile_by_name also knows "d435-hd" (the D435's 1280x720 mode),
/// left out of that list so that the sets made with `all` stay the same.
std::vector<std::string> profile_names();
Expected<SensorProfile> profile_by_name(const std::string& name);

/// Axial ToF noise [m] along the ray for range r [m], reflectance and cos of incidence.
double tof_sigma_m(const SensorProfile& profile, double range_m, double reflectance, double cos_incidence);
/// Structured-light depth noise [m] at depth z [m] (Nguyen et al. 2012), before quantisation.
double sl_sigma_m(const SensorProfile& profile, double z_m);
/// Depth step [m] of the disparity quantisation of a structured-light profile at depth z [m].
double sl_quantum_m(const SensorProfile& profile, double z_m);
/// Active-stereo depth noise [m] at depth z [m]: z^2 stereo_sigma_px / (fx baseline).
double stereo_sigma_m(const SensorProfile& profile, double z_m);

/// Builds a scene; the camera is placed for `profile` (top layer in view unless asked otherwise).
/// Fails when no box of the format fits the pallet.
Expected<Scene> make_scene(const ScenarioOptions& options, const SensorProfile& profile, std::uint64_t seed);

struct RenderOptions {
  bool noise = true;        ///< axial noise, quantisation noise of intensity
  bool invalid = true;      ///< random dropouts, low amplitude, projector shadows
  bool multipath = true;
  int supersampling = 0;    ///< 0: the profile's value; 1: one ray per pixel centre
  double noise_scale = 1.0; ///< multiplies every noise sigma
};

/// A rendered frame with its truth (top layer boxes in the camera frame) and its scene.
struct SimulatedFrame {
  std::string name;  ///< descriptive stem, e.g. "block_600x400_o3d303"
  Frame frame;
  Truth truth;
  Scene scene;
};

/// Ray casts the scene. The frame carries T_base_camera = T_world_camera (pallet frame as base).
SimulatedFrame render(const Scene& scene, const SensorProfile& profile, std::uint64_t seed,
                      const RenderOptions& options = {});

/// Truth of a scene in its camera frame (what render() puts into SimulatedFrame::truth).
Truth make_truth(const Scene& scene);

/// Many frames in memory, e.g. for benchmarks. Frame i uses seed mix(seed, i); each round of
/// patterns x profiles x scenes frames shows every combination of the lists once, in an order
/// shuffled from the seed; fill is drawn in [fill_min, fill_max], the removal mode at random when
/// the list holds several.
struct SetOptions {
  int count = 20;
  std::uint64_t seed = 1;
  ScenarioOptions scenario;             ///< base options; pattern, fill, removal are overridden
  std::vector<PatternFamily> patterns;  ///< empty: all families
  std::vector<std::string> profiles;    ///< empty: "o3d303"
  std::vector<RemovalMode> removals;    ///< empty: all modes
  std::vector<SceneFamily> scenes;      ///< empty: scenario.scene for every frame
  double fill_min = 1.0, fill_max = 1.0;
  RenderOptions render;
};
Expected<std::vector<SimulatedFrame>> generate_set(const SetOptions& options);
/// The seed generate_set() gives frame `index`.
std::uint64_t frame_seed(std::uint64_t seed, std::uint64_t index);

std::string to_string(PatternFamily pattern);
std::string to_string(RemovalMode mode);
std::string to_string(PalletKind pallet);
std::string to_string(SceneFamily family);
Expected<SceneFamily> parse_scene(const std::string& text);
Expected<PatternFamily> parse_pattern(const std::string& text);
Expected<RemovalMode> parse_removal(const std::string& text);
Expected<PalletKind> parse_pallet(const std::string& text);

/// The scene's suggested region of interest as a config snippet (detection.roi, base frame);
/// empty when the scene has none.
std::string roi_yaml(const Scene& scene);

/// A camera pose (T_world_camera) at `position` looking at `target` (world: z up), image x along
/// the world's x as far as the view allows; for scenes built by hand.
Eigen::Isometry3d camera_looking_at(const Eigen::Vector3d& position, const Eigen::Vector3d& target);

/// Pixel of a camera-frame point (no distortion); false when behind the camera.
bool project(const Intrinsics& intrinsics, const Eigen::Vector3d& p_camera, Eigen::Vector2d& pixel);
/// The four top-face corners of a truth box, camera frame [m].
std::vector<Eigen::Vector3d> truth_corners(const TruthBox& box);

/// 8-bit BGR preview: depth in a colour map (invalid black) with the truth outlines drawn.
/// Stored row-major as width*height*3 bytes (the caller writes it with OpenCV).
struct PreviewImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> bgr;
};
PreviewImage render_preview(const SimulatedFrame& frame);

}  // namespace palletd::sim
