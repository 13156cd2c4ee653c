// palletd detection: how far the camera moved on its mount since commissioning (a bumped bracket).
//
// At commissioning a reference frame of the cell is stored; each later frame is registered to it
// on the fixed geometry of the cell (floor, the pallet station's frame, posts, a cabinet), i.e.
// everything whose x/y lies outside the load's footprint: the region of interest's x/y grown by a
// margin, any height. PCL's ICP registers them: point-to-plane steps on projective correspondences
// (the reference is an organized grid), two coarse passes and a fine one, each moving only along the
// directions the fixed geometry constrains. Pure functions like detect(): no threads, files or
// logging.
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"
#include "palletd/detection/detection.hpp"

namespace palletd {

struct DriftParams {
  double footprint_margin_m = 0.05;  ///< grows the region's x/y footprint the load may occupy (overhang) [m]
  double max_correspondence_m = 0.05;  ///< ICP: farther point pairs are rejected (fine pass) [m]
  /// The coarse passes before the fine one: pairs up to this far apart [m], and the footprint grown
  /// by `coarse_margin_m` more, as before the drift is known the load's place in the view is not.
  double coarse_correspondence_m = 0.25;
  double coarse_margin_m = 0.15;
  /// Points are the means of stride x stride pixel blocks (the reference's stride is used later).
  int stride_px = 2;
  std::size_t min_points = 500;  ///< fewer fixed points (reference or matched): not measured
  /// A smaller share of the frame's fixed points matched at the end: not measured (the
  /// registration failed, or much of the cell changed or is hidden).
  double min_matched_share = 0.8;
  /// The frame's fixed points are thinned to at most this many for the fine pass (a quarter for the
  /// coarse one); the reference keeps all of its points.
  std::size_t max_points = 8000;
  int coarse_iterations = 10;  ///< ICP iterations at most, each coarse pass
  int max_iterations = 30;     ///< ICP iterations at most, fine pass
  /// A direction of motion whose point-to-plane information is below this share of the best
  /// constrained direction's is not measured (turns about the fixed points' centroid, counted as
  /// the turn times the points' extent, so that shifts and turns compare).
  double min_information_ratio = 0.003;
  /// Normals of the reference: the plane through this many nearest points (blocks).
  int normal_neighbours = 48;
};

/// Which motions the fixed geometry constrains. A flat floor alone shows a tilt and a change of
/// height, not a shift along it nor a turn about its normal.
struct DriftObservability {
  /// tx ty tz rx ry rz (shifts along and turns about the reference camera's axes, the turns about
  /// the fixed points' centroid): true = measured. An axis is not measured when it lies mostly in
  /// the span of the weakly constrained directions.
  std::array<bool, 6> axes{};
  int dofs = 0;      ///< how many independent directions of motion are constrained (0..6)
  std::string note;  ///< in words: what is measured and what is not
};

struct DriftEstimate {
  bool measured = false;
  std::string message;  ///< why not measured ("" when measured)
  /// The current camera in the reference camera's frame (identity: the camera did not move).
  /// Along motions the fixed geometry does not constrain, the least motion of the camera itself
  /// (shift of its origin, turn about it) is taken: a bumped camera turns about a point near itself.
  Eigen::Isometry3d T_reference_camera = Eigen::Isometry3d::Identity();
  double shift_mm = 0.0;             ///< norm of T_reference_camera's translation [mm]
  double angle_deg = 0.0;            ///< rotation angle of T_reference_camera [deg]
  std::size_t points = 0;            ///< fixed points matched to the reference at the end
  double matched_share = 0.0;        ///< `points` over the frame's fixed points used
  double rms_mm = 0.0;               ///< point-to-plane residual of the matched points [mm]
  int iterations = 0;                ///< ICP iterations, all passes
  DriftObservability observability;  ///< of this measurement (something may hide a part of the cell)
};

class DriftReference;
DriftEstimate measure_drift(const Frame& frame, const DriftReference& reference, const DriftParams& params);

/// The fixed geometry of the cell in the commissioning frame: its points outside the load, with
/// normals, in the reference camera's frame. Cheap to copy (shares its immutable data).
class DriftReference {
 public:
  struct Data;  ///< points, normals and PCL objects (drift_internal.hpp)

  DriftReference() = default;  ///< empty: measure_drift() answers "not measured"

  /// From the commissioning frame. `roi` is the load volume (detection.roi): without it there is
  /// no telling load from cell. A base-frame region needs the frame's T_base_camera. Fails when
  /// fewer than params.min_points fixed points are seen.
  static Expected<DriftReference> from_frame(const Frame& frame, const std::optional<RegionOfInterest>& roi,
                                             const DriftParams& params = {});

  [[nodiscard]] bool empty() const { return data_ == nullptr; }
  [[nodiscard]] std::size_t points() const;  ///< fixed points kept (pixel blocks)
  [[nodiscard]] const DriftObservability& observability() const;

 private:
  friend DriftEstimate measure_drift(const Frame& frame, const DriftReference& reference,
                                     const DriftParams& params);
  explicit DriftReference(std::shared_ptr<const Data> data) : data_(std::move(data)) {}
  std::shared_ptr<const Data> data_;
};

/// Registers the fixed geometry of `frame` to the reference. The frame's own T_base_camera is not
/// used: after a bump it is the old pose. The load is placed in the new view with the reference's
/// pose, then with the coarse estimate of the drift. Not measured (with the reason) when too few
/// fixed points match or too small a share of them: a drift of several degrees at a long range can
/// exceed the coarse passes' reach, and a repeating structure (conveyor rollers) can alias.
DriftEstimate measure_drift(const Frame& frame, const DriftReference& reference,
                            const DriftParams& params = {});

}  // namespace palletd
