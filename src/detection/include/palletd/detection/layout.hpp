// palletd detection, second half (paper Section IV): box layout search, seam evidence,
// refinement. Values in, values out.
//
// Entry points, in pipeline order:
//   SeamEvidence seams = build_seam_evidence(frame, cloud, layer);          // evidence inside the layer
//   LayoutResult found = find_layout(layer.polygons, formats, params, &seams);  // search
//   LayoutResult final = refine_layout(found, layer, &seams, params);        // millimetre fit
// or all three at once: solve_layout(frame, cloud, layer, formats, params).
//
// How the search, the seam ranking and the completion work: docs/architecture.md ("The layout
// stage") and the comments of src/detection/layout/.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/layer.hpp"
#include "palletd/detection/status.hpp"

namespace palletd {

/// The widest gap between two cartons of a layer the detector allows for [m]: cartons stand
/// 0-20 mm apart on real pallets. A box laid over two cartons may cover one such gap on each
/// side; an outline's piece is divided into whole cartons with gaps up to this.
inline constexpr double kMaxCartonGap_m = 0.02;

/// The layout search: best-first canonical tiling (exact, fast; the default) or the paper's
/// Algorithms 1-3 as published (breadth-first over corners, capped).
enum class SearchMode { kBestFirst, kPaper };

/// How the best-first search evaluates Area(box ∩ layer) for its placement table. grid_sat is the
/// default, chosen by measurement (tests/bench/layout): exact and the fastest; raster is
/// approximate (it can break exact ties, so ambiguity is under-reported); clip is exact and slower.
enum class AreaMethod {
  kGridSat,  ///< exact: cells between candidate lines clipped once, summed-area table over cells
  kRaster,   ///< layer rasterised in the layout frame (area_raster_cell_m), summed-area table
  kClip,     ///< exact clipping of the polygon with holes against each rectangle, every query
};

/// The layout search (src/detection/layout/search/): what counts as a box on the layer, the
/// budget, when two layouts tie.
struct LayoutSearchParams {
  SearchMode mode = SearchMode::kBestFirst;
  double a_min_fraction = 0.9;   ///< a box is on the layer when Area(B ∩ C) > a_min_fraction * Area(B)
  double a_max_fraction = 0.1;   ///< and overlaps the hypothesis by less than a_max_fraction * Area(B)
  /// best-first search: how far the true outline may lie outside the measured one [pixel pitches on
  /// the layer]. An outline traced through pixels places an edge between a layer pixel and its
  /// neighbour off the layer, uncertain by up to half a pitch where no mixed depth says more; at a
  /// coarse pitch the short steps of a staggered edge (a brick layer's 100 mm offsets are 5 pixels
  /// at 20 mm) come out washed into slopes that cut more than a tenth off the boxes there. For the
  /// a_min_fraction test a box's part outside the outline but within this distance of it counts
  /// as on the layer; the score stays Area(B ∩ C). It also widens the tie margin (see
  /// ambiguity_margin) and lets candidate box sides reach that far beyond the outline.
  /// solve_layout converts it to outline_tolerance_m with the layer's pixel pitch. 0 = the
  /// outline is exact (the paper). Larger values blur the recipe's formats: a box 20 mm smaller
  /// than its format passes more often.
  double outline_tolerance_pitches = 0.5;
  /// The same in metres, used by find_layout; solve_layout sets it from
  /// outline_tolerance_pitches when it is 0 [m].
  double outline_tolerance_m = 0.0;
  /// best-first search budget per call: node expansions (best-first queue pops), shared among the
  /// components and layout orientations in a fixed way. This is the primary budget and it is
  /// deterministic: the same frame gives the same layout whatever the machine load. Past it the
  /// best layout so far is returned with budget_exhausted. A 40-box layer needs a few thousand.
  std::size_t search_expansions = 20000;
  /// Wall-clock safety cap per call [ms], shared among the components; past it the best so far is
  /// returned with budget_exhausted (paper mode: the budget, with paper_max_hypotheses). In the
  /// best-first search it only ends searches the expansion budget would let run too long.
  double time_budget_ms = 200.0;
  /// Two materially different layouts whose scores differ by less than this share of the
  /// smallest box area, plus a strip outline_tolerance_m wide along the shortest box side, are
  /// near-equal: the seams choose between them, or they are tied (-> ambiguous).
  double ambiguity_margin = 0.02;
  double corner_angle_tol_deg = 10.0;  ///< an outline corner is orthogonal within this [deg]
  double line_merge_tol_m = 0.0;       ///< candidate lines closer than this merge [m]; 0 = auto
  std::size_t max_nodes = 400000;      ///< best-first search node cap
  std::size_t paper_max_hypotheses = 200000;  ///< paper mode cap on queued hypotheses
  AreaMethod area_method = AreaMethod::kGridSat;
  double area_raster_cell_m = 0.003;   ///< cell of AreaMethod::kRaster [m]
  /// Below this covered share of a component, its boxes match no recipe format (no_layout).
  double min_coverage = 0.8;
};

/// Seam evidence (src/detection/layout/evidence/): how the seam raster is built and weighed.
struct SeamParams {
  double cell_m = 0.0;            ///< raster cell [m]; 0 = the pixel pitch on the layer
  /// Deeper than the plane by more than max(depth_step_m, depth_noise_k * sigma) starts to look
  /// like a seam (fully at twice that); sigma = layer.diagnostics.plane_sigma_m when set, else
  /// the MAD of the layer pixels' plane residuals [m].
  double depth_step_m = 0.004;
  double depth_noise_k = 3.0;
  double intensity_weight = 0.8;  ///< weight of dark lines in the intensity image (0 = ignore intensity)
  /// A dark line (darker than the pixels on both sides of it) starts to look like a seam when it
  /// is intensity_noise_k times the intensity noise on the layer deep, fully at twice that.
  double intensity_noise_k = 3.0;
  double margin_m = 0.012;  ///< box interior = box shrunk by this before seam lookup [m]
  /// Weights of the seam-penalised search find_layout runs when the outline search finds more
  /// near-equal tilings than it lists (Area(B ∩ C) - weight * (interior seam mass +
  /// missing_weight * unsupported shared edge * cell)); its layouts only join the near-equal
  /// candidates the seams rank, never replace what the outline supports.
  double weight = 4.0;
  double missing_weight = 1.0;
};

/// The millimetre fit of the found boxes (src/detection/layout/refinement/).
struct RefineParams {
  bool enabled = true;               ///< solve_layout: run refine_layout
  double size_tolerance_m = 0.010;   ///< refined sizes stay within nominal +/- this [m] ...
  /// ... or grow up to this share over nominal (real cartons are built 1-5 % over their format;
  /// smaller than nominal stays bounded by size_tolerance_m, so a smaller format is not fitted).
  double max_oversize = 0.06;
  /// Prior spread of a box's own turn against the rest of its layer, and of a separate
  /// component's against the layer's orientation [deg]; 0 turns all boxes of a layer together.
  double yaw_sigma_deg = 0.5;
  /// A box whose fitted position is uncertain by more than this and by more than
  /// max_position_sigma_px pixel pitches (one sigma, the joint fit's; a box none of whose sides is
  /// measured along an axis counts with the fit's 50 mm prior) flags the layout: the sides that
  /// hold it are not seen well enough to promise it within a gripper's tolerance (cartons pressed
  /// together without a seam, an edge seen at a grazing angle) [mm]. 0 = never.
  double max_position_sigma_mm = 10.0;
  /// ... and than this many pixel pitches on the layer; 0 = the millimetres alone, whatever the
  /// camera. A coarse camera places a side it sees to about a pixel, but a gripper's tolerance
  /// does not grow with the camera's pixels: at 15 mm per pixel a box placed to 11 mm (one sigma)
  /// came out 16.5 mm off, beyond the 15 mm a pick allows. An integrator who would rather have a
  /// coarse camera's layouts unflagged sets 1 (a box placed no better than one pitch is held by
  /// its prior and its neighbours, not by what the frame shows).
  double max_position_sigma_px = 0.0;
  /// The layer's turn uncertain (one sigma, from the slopes of the sides the fit measured) by more
  /// than this flags the layout [deg]; 0 = never. A layout counts within 2 degrees of the cartons'
  /// turn: this limit holds it as max_position_sigma_mm holds 15 mm (two thirds). A single carton
  /// 17 x 12 pixels on a coarse camera measures its turn to about 1.6 degrees.
  double max_yaw_sigma_deg = 1.3;
};

/// What the outline leaves open (src/detection/layout/completion/, the uncovered flag).
struct CompletionParams {
  /// Boxes the outline cuts where the depth ends (beyond the range, too dark; see
  /// LayerSurroundings): a box of the recipe is placed across such an edge when at least this
  /// share of it is on the layer, two of its sides (one per axis) lie on seen edges of the
  /// outline or on neighbours, and its part off the layer is unseen, not seen lower. 0 = never.
  double unseen_min_fraction = 0.4;
  /// A piece of a component that no box covers, wider than the gaps between boxes and larger
  /// than this share of the smallest box, flags the layout ambiguous: the outline is not
  /// explained there (a wrong tiling, a box of another format). 0 = never.
  double uncovered_flag_fraction = 0.4;
};

/// The layout stage's parameters, one struct per phase. The configuration keeps them as one
/// flat section (detection.layout in config/palletd.yaml).
struct LayoutParams {
  LayoutSearchParams search;
  SeamParams seams;
  RefineParams refine;
  CompletionParams completion;
};

/// Seam evidence: a raster in the layer frame of how much each spot looks like a gap between
/// boxes (0 = flat box top, 1 = seam: depth below the plane, no measurement, a dark line in the
/// intensity image).
struct SeamEvidence {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();  ///< layer-frame corner of cell (0, 0) [m]
  double cell_m = 0.003;                               ///< cell size [m]
  int width = 0;                                       ///< cells along layer x
  int height = 0;                                      ///< cells along layer y
  std::vector<float> seam;                             ///< row-major (row = y), 0..1
  double strength = 0.0;  ///< share of layer cells that look like seams (> 0.5); 0 = no evidence
  double depth_threshold_m = 0.0;  ///< depth below the plane where seams start (noise-aware) [m]
  /// The intensity of the box tops on the same raster (pixels on the plane within
  /// depth_threshold_m, mean per cell) and 1 where a cell has such pixels, else both 0; empty
  /// without an intensity image. Tape along a carton's flaps shows in it (evidence/tape.hpp).
  std::vector<float> tops, tops_seen;

  [[nodiscard]] bool empty() const { return width <= 0 || height <= 0 || seam.empty(); }
  [[nodiscard]] float at(int ix, int iy) const {
    return seam[static_cast<std::size_t>(iy) * static_cast<std::size_t>(width) +
                static_cast<std::size_t>(ix)];
  }
};


/// Builds the seam raster from the frame (depth, optional intensity), its organized cloud and
/// the layer found by the first half. Empty when the layer status is not ok.
SeamEvidence build_seam_evidence(const Frame& frame, const OrganizedCloud& cloud,
                                 const LayerResult& layer, const SeamParams& params = {});

/// What the camera saw on and around the layer, resampled into the layer frame: where the layer
/// may go on unseen (no depth, or something above it in the view) and where the view shows the
/// surface lower (the layer ends there). Built with the pixels' viewing rays, so pixels without
/// depth land where they belong on the plane.
struct LayerSurroundings {
  enum Label : std::uint8_t { kUnseen = 0, kLevel = 1, kBelow = 2 };
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();  ///< layer-frame corner of cell (0, 0) [m]
  double cell_m = 0.01;                                ///< cell size [m]
  int width = 0;                                       ///< cells along layer x
  int height = 0;                                      ///< cells along layer y
  std::vector<std::uint8_t> label;                     ///< row-major (row = y), a Label per cell

  [[nodiscard]] bool empty() const { return width <= 0 || height <= 0 || label.empty(); }
  [[nodiscard]] std::uint8_t at(int ix, int iy) const {
    return label[static_cast<std::size_t>(iy) * static_cast<std::size_t>(width) + static_cast<std::size_t>(ix)];
  }
  /// The label at a layer-frame point (unseen outside the raster).
  [[nodiscard]] std::uint8_t at_point(const Eigen::Vector2d& p_m) const;
  /// Whether anything is seen (level or below) along the ray from p_m in direction dir (unit,
  /// layer frame) within reach_m.
  [[nodiscard]] bool seen_within(const Eigen::Vector2d& p_m, const Eigen::Vector2d& dir, double reach_m) const;
};

/// Whether the layout stage completes boxes where the depth ends on this layer: completion is on
/// and the outline runs somewhere along pixels without depth or along the image border (only
/// there can boxes go on unseen). The surroundings are read only then.
bool completes_unseen(const LayerResult& layer, const CompletionParams& params);

/// The layer's surroundings within reach_m of its outline (cells outside the image: unseen).
/// A pixel is at the layer's level within max(15 mm, the layer's passthrough band) of the plane,
/// below it further down, unseen without depth or further up. Empty when the layer is not ok.
LayerSurroundings build_layer_surroundings(const Frame& frame, const OrganizedCloud& cloud,
                                           const LayerResult& layer, double reach_m);

/// A pixel on the layer's rim that straddles the edge: a ToF pixel whose footprint lies partly on
/// the top and partly on the surface beyond returns a depth between the two, in proportion to
/// the light from each (mixed pixel). Where its viewing ray meets the plane, and the share of its
/// footprint on the top estimated from that depth.
struct RimPixel {
  Eigen::Vector2f at_m = Eigen::Vector2f::Zero();  ///< layer frame [m]
  float top_share = 0.f;                           ///< 0..1
};

/// The layer's mixed rim pixels: below the level band (build_layer_surroundings) next to a pixel
/// of the layer (LayerResult::point_pixels, 4-neighbourhood), with the pixel straight on beyond
/// them lower still, at least min_drop_m below the plane. top_share = 1 - (its depth below the plane) / (the
/// depth beyond), averaged over the directions that qualify. Cameras that blank mixed pixels
/// (flying-pixel filters) give none. Empty when the layer is not ok.
std::vector<RimPixel> build_layer_rim(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                                      double min_drop_m = 0.05);

/// Interior box sides of a layout (sides with a neighbour's top just beyond them, corners left
/// out) and the part of them where the seam raster shows a seam (> 0.5 from just inside the box
/// to the neighbour) or the layer's outline a gap. Each shared side counts from both boxes [m].
struct InteriorSeams {
  double length_m = 0.0;
  double seen_m = 0.0;
  /// Boxes along whose middle the tops' intensity shows a band of tape (the flaps' closure);
  /// counted only where under InteriorSeams::kTapeAskedShare of the interior sides show a seam:
  /// cartons pressed together show their tape, a slip sheet is plain.
  std::size_t taped_boxes = 0;
  static constexpr double kTapeAskedShare = 0.25;
  [[nodiscard]] double seen_share() const { return length_m > 0.0 ? seen_m / length_m : 0.0; }
};

/// What a box's support rests on: the outline and seams around it (find_layout, again after
/// refine_layout) and how well the joint fit placed it (refine_layout).
struct BoxEvidence {
  double inside = 0.0;          ///< share of the box's top inside the layer's outline
  double interior_seam = 0.0;   ///< strongest seam line across its top (it may be two boxes), 0..1
  double edge_seams = 1.0;      ///< share of the sides it shares with neighbours that show a seam
  bool shared_sides = false;    ///< it has a neighbour (else edge_seams is 1)
  double position_sigma_m = -1.0;  ///< standard deviation of the fitted centre, worse axis; -1 = not fitted
  /// Standard deviation of the layer's turn that the box follows, from the slopes of every side
  /// the fit measured (inverse-variance sum over the layer) [rad]; -1 = not fitted.
  double yaw_sigma_rad = -1.0;
  double refine_shift_m = 0.0;     ///< how far the fit moved it from where the search put it [m]
  /// The joint fit placed it more than a quarter of its short side from where the search put it:
  /// the sides measured around it contradict the layout there, so it keeps the search's place,
  /// unconfirmed (position_sigma_m stays -1).
  bool fit_rejected = false;
  bool contested = false;  ///< the runner-up layout of its component has no box of its size here
  /// Where the recipe makes the box two boxes of another format: the strongest seam line across
  /// it, 0..1; -1 = no such format.
  double split_seam = -1.0;
  /// Where it and a neighbour (or it and three neighbours two by two) make one box of another
  /// recipe format: the strongest seam line between them (across the block's middle), the
  /// weakest over such neighbours, 0..1; -1 = none.
  double join_seam = -1.0;
  /// Side lengths measured from its own sides alone (the outline or a seam seen on both opposite
  /// sides, no prior), long and short [m]; -1 where a side of the pair was not seen. The recipe
  /// check compares them with the format (recipe_check.hpp).
  double measured_long_m = -1.0;
  double measured_short_m = -1.0;
  /// The same as its share of a row of boxes pressed together (no seam seen) between two seen
  /// sides: an upper bound, as gaps not seen count in [m]; -1 where there is no such row.
  double run_long_m = -1.0;
  double run_short_m = -1.0;
  /// The tops' intensity shows a band of tape across its middle, along its short side, and none
  /// along its long side. A carton's flaps close lengthwise, so the box is part of a carton laid
  /// the other way: two boxes where one carton stands, or boxes of a format the layer is not
  /// built of (recipe_check.hpp). Not looked for on near-square boxes.
  bool tape_across = false;
  /// The tops' intensity shows a band across the box along the middle of each of its halves, and
  /// none along its long side: two cartons laid the other way under one box, each taped
  /// lengthwise (a format twice the layer's carton; recipe_check.hpp).
  bool tape_halves = false;
};

/// One box of a layout: where it lies (layer frame) and how well the measurements support it.
struct LayoutBox : Box2d {
  double score = 0.0;          ///< 0..1
  int component = 0;           ///< index of the component it lies on
  bool partly_unseen = false;  ///< completed across an outline edge where the depth ends
  BoxEvidence evidence;
};

/// Why a layout search flagged its answer (LayoutResult::ambiguous); several may hold.
struct LayoutDoubts {
  bool tied_layouts = false;  ///< near-equal layouts of a component the seams did not separate (runner_up)
  /// A box, or two side by side, could as well be boxes of another recipe format on the same
  /// footprint (one box where two stand, or two where one stands) and the seams did not decide.
  bool undecided_formats = false;
  bool completion =
      false;               ///< boxes completed where the depth ends could stand otherwise, or none fits there
  bool uncovered = false;  ///< a piece of the layer more than a gap wide that no box covers
};

/// Result of the layout search for all components of a layer.
struct LayoutResult {
  DetectionStatus status = DetectionStatus::kNoLayout;
  std::string reason;                ///< a sentence when status != ok
  std::vector<LayoutBox> boxes;
  bool ambiguous = false;            ///< another layout scores (nearly) the same
  LayoutDoubts doubts;               ///< why `ambiguous` is set
  bool budget_exhausted = false;     ///< time budget or node cap reached: best so far returned
  /// The time budget (a safety cap the machine's speed decides), not the node cap, ended a search.
  bool clock_ran_out = false;
  double coverage = 0.0;             ///< covered share of the layer area
  double score = 0.0;                ///< sum over components of the search score [m^2]
  double runner_up_gap = -1.0;       ///< score gap to the best different layout [m^2]; -1 = none
  std::vector<Box2d> runner_up;      ///< that layout (diagnostics), empty if none
  int runner_up_component = -1;      ///< the component it lays out; -1 = none
  /// Boxes completed across outline edges where the depth ends (LayoutParams::unseen_min_fraction).
  std::size_t completed_unseen = 0;
  InteriorSeams interior_seams;  ///< of the boxes returned (solve_layout)
  double pixel_pitch_m = 0.0;    ///< the layer's pixel pitch (solve_layout) [m]
  /// Mixed pixels on the layer's rim per pixel pitch of outline (build_layer_rim; solve_layout):
  /// a ToF camera mixes the top and the surface beyond along most of a stepped edge and shows
  /// sub-pixel seams the same way; stereo, structured light and flying-pixel filters show none.
  double rim_share = 0.0;
  std::size_t hypotheses_visited = 0;
  std::size_t search_expansions = 0;  ///< best-first search: node expansions used (the budget's unit)
  double search_ms = 0.0;
};

InteriorSeams measure_interior_seams(const std::vector<LayoutBox>& boxes, const SeamEvidence& seams,
                                     const std::vector<PolygonWithHoles>& polygons);

/// Why a recipe's formats cannot be searched, or "" when they can: none given, a zero, negative
/// or invalid size, the short side listed first.
std::string box_formats_problem(const std::vector<BoxFormat>& formats);

/// Memory the layout search keeps from one search to the next: its node pool, queue and frontier
/// table, which grow to tens of MB on wide recipes. A caller that detects frame after frame (a
/// DetectionWorkspace) passes one in, so the search reuses that memory instead of taking it from
/// the allocator and giving it back on every search. Move-only; one thread.
class SearchMemory {
 public:
  struct Storage;  ///< defined with the search (src/detection/layout/search/)
  /// Keeps whatever the searches took (a batch tool's choice).
  SearchMemory();
  /// Takes `kept_pool_bytes` of node pool and room for `kept_nodes` nodes (their queue and
  /// frontier table too) now, writing every page, and keeps exactly that: a search that needs
  /// more takes the rest for itself and gives it back when it ends. A daemon's resident memory
  /// then stays the same whatever its searches reach, which depends on the time cap and so on
  /// the machine's load.
  SearchMemory(std::size_t kept_pool_bytes, std::size_t kept_nodes);
  ~SearchMemory();
  SearchMemory(SearchMemory&&) noexcept;
  SearchMemory& operator=(SearchMemory&&) noexcept;
  SearchMemory(const SearchMemory&) = delete;
  SearchMemory& operator=(const SearchMemory&) = delete;
  /// The containers, made on first use (a moved-from memory makes new ones).
  [[nodiscard]] Storage& storage();

 private:
  std::unique_ptr<Storage> storage_;
};

/// Finds the box layout of each component. `seams` may be null (outline only). With
/// `surroundings`, boxes the outline cuts where the depth ends are completed
/// (LayoutParams::unseen_min_fraction). `memory` may be null (the searches allocate their own).
LayoutResult find_layout(const std::vector<PolygonWithHoles>& components,
                         const std::vector<BoxFormat>& formats, const LayoutParams& params,
                         const SeamEvidence* seams, const LayerSurroundings* surroundings = nullptr,
                         SearchMemory* memory = nullptr);

/// Fits the found boxes to the measured outline (layer points) and to seam lines so that
/// positions reach millimetres; sizes stay at the nominal format within
/// refine_size_tolerance_m. Recomputes per-box scores. `seams` may be null. With
/// `surroundings`, outline stretches where the depth ends (nothing seen beyond within 50 mm)
/// are not taken for box edges. With `rim`, an outline side that does not face the camera is
/// placed within the footprint of the mixed pixels beyond it (their top share) instead of at
/// the middle of that footprint.
LayoutResult refine_layout(const LayoutResult& found, const LayerResult& layer,
                           const std::vector<BoxFormat>& formats, const SeamEvidence* seams,
                           const LayoutParams& params, const LayerSurroundings* surroundings = nullptr,
                           const std::vector<RimPixel>* rim = nullptr);

/// What the layout stage reads from the frame about a layer, whatever the formats: the seams and
/// the mixed pixels along the rim. Built once per layer; every layout of that layer may reuse it.
struct LayerEvidence {
  SeamEvidence seams;
  std::vector<RimPixel> rim;
  /// The layer's surroundings out to around_reach_m, for layouts of boxes no longer than that
  /// (solve_layout builds its own for longer boxes, or when around_reach_m is 0).
  LayerSurroundings around;
  double around_reach_m = 0.0;
};

/// build_seam_evidence + build_layer_rim.
LayerEvidence build_layer_evidence(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                                   const SeamParams& params);

/// build_layer_evidence + find_layout + refine_layout.
LayoutResult solve_layout(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                          const std::vector<BoxFormat>& formats, const LayoutParams& params,
                          SearchMemory* memory = nullptr);

/// find_layout + refine_layout on evidence built before for this layer and frame.
LayoutResult solve_layout(const Frame& frame, const OrganizedCloud& cloud, const LayerResult& layer,
                          const LayerEvidence& evidence, const std::vector<BoxFormat>& formats,
                          const LayoutParams& params, SearchMemory* memory = nullptr);

/// The recipe format that two boxes of format `half` make side by side (along their short sides,
/// within 12 mm), or -1.
int doubled_format(const std::vector<BoxFormat>& formats, const BoxFormat& half);
/// The recipe format two boxes of which make `whole` side by side (the reverse of
/// doubled_format()), or -1.
int halved_format(const std::vector<BoxFormat>& formats, const BoxFormat& whole);

/// Area of the intersection of a polygon with holes and an axis-aligned rectangle [m^2] (exact).
double clipped_area(const PolygonWithHoles& polygon, double x0, double y0, double x1, double y1);

}  // namespace palletd
