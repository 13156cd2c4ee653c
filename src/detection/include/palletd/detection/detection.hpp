// palletd detection: frame in, layout out. A pure function: no threads, files or logging inside;
// everything it decides is in its result.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/gripper.hpp"
#include "palletd/detection/health.hpp"
#include "palletd/detection/layer.hpp"
#include "palletd/detection/status.hpp"
#include "palletd/detection/layout.hpp"
#include "palletd/detection/recipe_check.hpp"

namespace palletd {

/// Order in which boxes are reported to the robot (pick index 0 first). Distances from the robot
/// base (without a calibration: from the layer's centroid) within 10 mm of each other are a tie,
/// broken by x (again within 10 mm), then y: boxes placed symmetrically keep one order whichever
/// way a few millimetres of pose noise tip them.
enum class PickOrder {
  kFarCornerFirst,  ///< from the corner furthest from the robot base (or camera) inwards
  kRowMajor,        ///< by base-frame x in rows (within half the smallest box side), each row by y
  kNearestFirst,    ///< nearest to the robot base (or camera) first
};

/// The work volume: an axis-aligned box; what stands beside or above it is left out of every
/// stage (config detection.roi). What lies below it (the floor, a lower level) stays visible as
/// where the layer ends. In the robot base frame it needs the frame's
/// camera_to_base.
struct RegionOfInterest {
  enum class Frame { kBase, kCamera };
  Frame frame = Frame::kBase;
  Eigen::Vector3d min_m = Eigen::Vector3d::Zero();  ///< lower corner [m]
  Eigen::Vector3d max_m = Eigen::Vector3d::Zero();  ///< upper corner [m]

  [[nodiscard]] bool contains(const Eigen::Vector3d& p_m) const {
    return (p_m.array() >= min_m.array()).all() && (p_m.array() <= max_m.array()).all();
  }
  friend bool operator==(const RegionOfInterest& a, const RegionOfInterest& b) {
    return a.frame == b.frame && a.min_m == b.min_m && a.max_m == b.max_m;
  }
};

/// The pallet the load stands on (config `pallet`).
struct PalletParams {
  /// Height of the empty pallet's top deck in the base frame [m]; null = unknown. With the
  /// frame's camera_to_base it gives the layer's height above the pallet, the layers left (with
  /// the formats' heights), and `empty` when the top level is the pallet itself.
  std::optional<double> top_z_m;
  /// A layer height off a whole number of box heights by more than this share of a box height
  /// flags the result (a missing or extra layer, a wrong recipe).
  double height_tolerance = 0.2;
};

struct DetectionParams {
  std::optional<RegionOfInterest> roi;  ///< null: the whole view
  PalletParams pallet;
  PlaneParams plane;
  LayerParams layer;
  ContourParams contour;
  LayoutParams layout;
  PickOrder pick_order = PickOrder::kFarCornerFirst;
  /// The gripper (config `gripper`); null: no pickability, TCP poses or groups.
  std::optional<GripperParams> gripper;
  RecipeCheckParams recipe_check;  ///< when the measured cartons disagree with the recipe
  DepthNoiseModel noise_model;  ///< the camera's depth noise, for the frame's health (`health.noise_model`)
};

/// The evidence a box's score is computed from (JSON `score_terms`): why a box scores low.
struct ScoreTerms {
  /// The search's support: inside x (1 - interior_seam) x (0.5 + 0.5 edge_seams).
  double support = 0.0;
  double inside = 0.0;         ///< share of the box's top inside the layer's outline
  double edge_seams = 1.0;     ///< share of the sides shared with neighbours where a seam shows (1: none shared)
  double interior_seam = 0.0;  ///< strongest seam line across its top, 0..1 (it may be two boxes)
  double position_sigma_mm = -1.0;  ///< standard deviation of the fitted position, worse axis; -1 = not fitted
  double refine_shift_mm = 0.0;     ///< how far the fit moved it from where the search put it
  double pitch_mm = 0.0;            ///< pixel pitch on the layer
  /// Mixed pixels along the layer's rim per pixel of outline: a time-of-flight camera shows even
  /// sub-pixel seams as dips; stereo and structured light (near 0) smooth narrow seams away.
  double rim_share = 0.0;
  int layout_formats = 1;           ///< formats the layout uses (a mix is decided by seams alone)
  bool partly_unseen = false;       ///< completed where the depth ends
  bool contested = false;           ///< the closest other arrangement has no box here
  bool layout_ambiguous = false;    ///< the layout is flagged ambiguous
  bool outline_unobserved = false;  ///< the layer's outline runs along missing depth
};

/// One detected box, camera frame [m], conventions of shared/spec/detections.md.
struct DetectedBox {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();     ///< centroid of the top face
  Eigen::Vector3d long_axis = Eigen::Vector3d::UnitX(); ///< unit, along the long side
  Eigen::Vector3d normal = -Eigen::Vector3d::UnitZ();   ///< unit, toward the camera
  double long_m = 0.0, short_m = 0.0;                   ///< size of the top face [m]
  int format = 0;        ///< index into the recipe's formats
  /// Confidence 0..1: the estimated probability that the box is right (position within 15 mm,
  /// yaw within 2 deg, right format), calibrated on generated frames (box_confidence()).
  double score = 0.0;
  ScoreTerms score_terms;  ///< what the score is computed from
  int pick_index = 0;
  /// Completed across an outline edge where the depth ends: part of its top was not seen, so its
  /// far side is placed by the format, not measured (LayoutParams::unseen_min_fraction).
  bool partly_unseen = false;
  /// Side lengths measured from the box's own opposite sides (outline or seams), long and short
  /// [m]; -1 where a side of the pair was not seen (JSON `measured_size`, null there).
  double measured_long_m = -1.0, measured_short_m = -1.0;
  /// Upper bounds where its own sides were not both seen: its share of a row of boxes pressed
  /// together between two seen sides (gaps not seen count in) [m]; -1 where there is none.
  double run_long_m = -1.0, run_short_m = -1.0;
  /// A band of tape runs across its middle and none along it (BoxEvidence::tape_across).
  bool tape_across = false;
  /// A band runs across each of its halves and none along it (BoxEvidence::tape_halves).
  bool tape_halves = false;
  Box2d in_layer;        ///< the same box in the layer frame
  std::optional<Eigen::Vector3d> base_position;  ///< [m] when T_base_camera is known
  std::optional<double> base_yaw_deg;            ///< [deg] (-180, 180]
  std::optional<BoxPick> pick;  ///< with a gripper: pickable now, why not, the TCP
};

/// Sorts `boxes` by `order` (their base_position when set, else in_layer) and numbers their
/// pick_index 0, 1, ... (the order detect() starts the pick planning from).
void sort_by_pick_order(std::vector<DetectedBox>& boxes, PickOrder order);

struct Detection {
  DetectionStatus status = DetectionStatus::kBadFrame;
  std::string message;
  std::optional<RegionOfInterest> roi;  ///< the work volume the detection ran in (null: the whole view)
  std::map<std::string, double> timing_ms;  ///< "total" plus per stage
  Plane plane_camera;
  double layer_area_m2 = 0.0;
  double coverage = 0.0;
  /// The estimated probability that the whole layout is exact (every box right, none missing or
  /// extra), from the boxes' confidences and the flags (layout_confidence()); 0 without boxes.
  double layout_confidence = 0.0;
  bool ambiguous = false;
  bool budget_exhausted = false;
  bool clipped_by_image_border = false;
  /// A large part of the layer's outline runs along pixels without depth (beyond the sensor's
  /// range, a dark or shiny surface): the outline there is where the depth ends; `message`
  /// says so even when status is ok.
  bool outline_unobserved = false;
  /// Interior box sides of the layout and how much of them shows a seam (slip-sheet evidence).
  InteriorSeams interior_seams;
  /// Why `ambiguous` is set: which alternatives tie and on what evidence; empty when not.
  std::string ambiguity_reason;
  /// The same as categories, one per cause (several may hold); empty when not ambiguous.
  std::vector<AmbiguityKind> ambiguity_kinds;
  /// The top layer's height above the pallet's top (PalletParams::top_z_m and camera_to_base) [m].
  std::optional<double> height_above_pallet_m;
  /// Layers on the pallet counting the top one: the height above the pallet in box heights (the
  /// heights of the boxes found, formats[].height_m); null when a height is unknown.
  std::optional<int> layers_remaining;
  /// The height above the pallet is not a whole number of box heights (ambiguous is set too).
  bool height_off_layers = false;
  std::vector<DetectedBox> boxes;
  /// The boxes' measured sides against the recipe's formats (status recipe_mismatch when they
  /// disagree; the boxes are then dropped, the measurements stay here).
  RecipeCheck recipe_check;
  /// The recipe gave a size range, not formats (detect_unknown_cartons()): the boxes' sizes were
  /// measured on the frame and their format is -1.
  bool formats_measured = false;
  /// With a gripper: the picks that can be made now, in pick order (each pickable box is in one).
  std::vector<PickGroup> groups;
  FrameHealth health;  ///< how well the camera saw the cell in this frame (every readable frame)
  LayerResult layer;  ///< the first half's result, for overlays and diagnostics
};

/// Buffers detect() fills per frame, owned by the caller so that a loop over frames reuses them
/// (no allocation for them once they have the frame's size: the organized cloud alone is 3.7 MB
/// at 640x480). One workspace per thread; its contents after a call are scratch.
struct DetectionWorkspace {
  RayTable rays;         ///< viewing rays of the last frame's intrinsics; rebuilt when they change
  OrganizedCloud cloud;  ///< organized cloud of the last frame [m]
  SearchMemory search;   ///< the layout search's node pool and queues, kept between frames
};

/// Runs the whole pipeline on one frame with the given box formats, reusing `workspace`.
Detection detect(const Frame& frame, const std::vector<BoxFormat>& formats,
                 const DetectionParams& params, DetectionWorkspace& workspace);

/// The same with a temporary workspace (the cloud is allocated for this call).
/// `rays` may be empty; a matching table is then built (pass one in to reuse it frame after frame).
Detection detect(const Frame& frame, const std::vector<BoxFormat>& formats,
                 const DetectionParams& params, RayTable* rays = nullptr);

}  // namespace palletd
