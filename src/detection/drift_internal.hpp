// The camera mount drift's pieces (drift.hpp): the reference's data, the point-to-plane normal
// equations, the ICP passes and the observability of the fixed geometry.
#pragma once

#include <cstddef>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "palletd/core/frame.hpp"
#include "palletd/detection/drift.hpp"

namespace palletd {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;  ///< a small motion: shift [m], then turn [rad]

/// Pinhole projection onto the grid of stride x stride pixel blocks: grid column = fx x / z + cx.
struct GridCamera {
  int width = 0, height = 0;
  float fx = 0.0F, fy = 0.0F, cx = 0.0F, cy = 0.0F;
};

/// The points' x/y in the region's frame outside its footprint grown by `margin_m`: the cell.
bool outside_footprint(const RegionOfInterest& roi, double margin_m, const Eigen::Vector3d& p_roi);

/// Point-to-plane normal equations of small motions x (shift, turn about the camera's origin):
/// residual r = n . (p + t + w x p - q); H = sum w J^T J, g = sum w J^T r with the pairs' weights w.
struct NormalEquations {
  Matrix6d H = Matrix6d::Zero();
  Vector6d g = Vector6d::Zero();
  std::size_t count = 0;                                 ///< point pairs
  Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();  ///< of the points
  double extent_m = 1.0;                                 ///< RMS distance of the points from their centroid
  double range_m = 1.0;                                  ///< RMS distance of the points from the camera
  double rms_m = 0.0;                                    ///< RMS point-to-plane residual (weighted)

  void add(const Eigen::Vector3d& p, const Eigen::Vector3d& n, double residual_m, double weight);
  /// Fills H's lower half (add() updates the upper one), sets centroid, extent and range.
  void finish();

 private:
  Eigen::Vector3d sum_m_ = Eigen::Vector3d::Zero();
  double sum_sq_m2_ = 0.0;
};

/// The normal equations of the pairs `pairs` (source index, target index, distance). A pair's
/// weight falls with its distance (Tukey's biweight, zero at `max_distance_m`): what stands where
/// the reference saw the cell (a person, a forklift) is far from its pair and weighs nothing, and
/// a pair crossing the gate does not make the step jump.
NormalEquations point_to_plane_equations(const pcl::PointCloud<pcl::PointNormal>& source,
                                         const pcl::PointCloud<pcl::PointNormal>& target,
                                         const pcl::Correspondences& pairs, double max_distance_m);

/// The information of the reference's own points (unit weights, no residual): what its fixed
/// geometry can constrain.
NormalEquations reference_equations(const pcl::PointCloud<pcl::PointNormal>& target);

/// The directions of motion an information constrains: those whose information is at least
/// `min_ratio` of the largest, in coordinates y where turns pivot about the points' centroid and
/// count as the turn times the points' extent [m] (so that shifts and turns compare).
///
/// A motion along the other directions barely changes the residual, so any amount of it fits the
/// data; of those the one taken is the least motion of the camera itself (its origin's shift and
/// its turn times `range_m`): a camera bumped on its mount turns about a point near itself. (Least
/// motion in y instead would trade a turn about the camera for a turn about the far centroid plus
/// a large shift, and leaving out a weak direction would then bend the constrained ones.)
struct MotionSubspace {
  Matrix6d to_camera = Matrix6d::Identity();       ///< x (shift, turn about the camera) = to_camera * y
  Eigen::Matrix<double, 6, Eigen::Dynamic> basis;  ///< orthonormal columns in y
  Eigen::Matrix<double, 6, Eigen::Dynamic> weak;   ///< the other directions, camera coordinates x
  double range_m = 1.0;                            ///< weighs turns against shifts (camera motion)
  double min_ratio = 0.0;                          ///< the share it was chosen with
};
/// Turns pivot about the points' centroid, or about the camera (scaled by the range): a camera
/// bumped on its mount turns about a point near itself, and the shift along the floor that comes
/// with it is then constrained by the floor's tilt.
enum class Pivot { kCentroid, kCamera };
MotionSubspace constrained_subspace(const NormalEquations& eq, double min_ratio,
                                    Pivot pivot = Pivot::kCentroid);

/// The motion within `subspace` that minimises the normal equations (camera coordinates x); along
/// the directions these pairs hardly constrain, the least camera motion.
Vector6d solve_within(const NormalEquations& eq, const MotionSubspace& subspace);

/// T without its motion along the subspace's weak directions, taken as the least camera motion
/// (T as a small motion: shift and rotation vector).
Eigen::Isometry3d restrict_to(const Eigen::Isometry3d& T, const MotionSubspace& subspace);

/// The constrained directions of the normal equations, per axis and in words.
DriftObservability observability_of(const NormalEquations& eq, double min_ratio);

/// A small motion as a rigid transform (rotation by the angle-axis vector, then shift).
Eigen::Isometry3d motion_transform(const Vector6d& x);

struct DriftReference::Data {
  RayTable rays;  ///< of the reference frame's intrinsics; a later frame must match them
  int stride_px = 1;
  RegionOfInterest roi;
  Eigen::Isometry3d T_roi_camera =
      Eigen::Isometry3d::Identity();  ///< the reference camera in the region's frame
  double footprint_margin_m = 0.0;
  /// The fixed points with their normals, reference camera frame, placed on the pinhole grid of
  /// `grid` (lens distortion undone); NaN where no fixed point projects.
  pcl::PointCloud<pcl::PointNormal>::Ptr target;
  GridCamera grid;
  std::size_t points = 0;
  MotionSubspace subspace;         ///< the directions the fixed points constrain
  MotionSubspace strong_subspace;  ///< those constrained best (the coarse pass's first stage)
  DriftObservability observability;
};

/// One ICP pass (PCL: projective correspondences on the reference's grid, point-to-plane steps
/// within a subspace of the reference's constrained directions), from `T_initial`. The result
/// maps source into reference camera.
struct IcpPass {
  Eigen::Isometry3d T_reference_camera = Eigen::Isometry3d::Identity();
  int iterations = 0;
};
struct IcpSettings {
  const MotionSubspace* subspace = nullptr;  ///< the directions the steps move along (required)
  double max_correspondence_m = 0.05;
  int max_iterations = 30;
  double min_step_m = 2e-5;     ///< a step below this shift ...
  double min_step_deg = 0.002;  ///< ... and this turn ends the pass
};
IcpPass run_icp_pass(const DriftReference::Data& reference,
                     const pcl::PointCloud<pcl::PointNormal>::Ptr& source, const Eigen::Isometry3d& T_initial,
                     const IcpSettings& settings);

/// The normal equations of `source` under `T_reference_camera` against the reference: the pairs
/// within `max_correspondence_m`, for the residual and the observability at convergence.
NormalEquations evaluate_alignment(const DriftReference::Data& reference,
                                   const pcl::PointCloud<pcl::PointNormal>& source,
                                   const Eigen::Isometry3d& T_reference_camera, double max_correspondence_m);

}  // namespace palletd
