// The drift's ICP (drift_internal.hpp): PCL's ICP loop with projective correspondences on the
// reference's organized grid (no kd-tree: one projection per point) and a point-to-plane step
// that moves only along the directions the fixed geometry constrains.
#include <algorithm>
#include <cmath>
#include <vector>

#include <pcl/common/transforms.h>
#include <pcl/registration/correspondence_estimation_organized_projection.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation.h>
#include <pcl/search/kdtree.h>

#include "drift_internal.hpp"

namespace palletd {

namespace {

using SourceCloud = pcl::PointCloud<pcl::PointNormal>;
using TargetCloud = pcl::PointCloud<pcl::PointNormal>;
using Projection = pcl::registration::CorrespondenceEstimationOrganizedProjection<pcl::PointNormal,
                                                                                  pcl::PointNormal, double>;

/// The point-to-plane step of PCL's ICP loop: normal equations of the pairs, solved within the
/// reference's constrained directions (the same in every iteration). Counts its calls.
class ObservablePointToPlane
    : public pcl::registration::TransformationEstimation<pcl::PointNormal, pcl::PointNormal, double> {
 public:
  static constexpr double kMaxTurn_rad = 3.14159265358979323846 / 180.0;
  static constexpr double kMaxShift_m = 0.02;

  ObservablePointToPlane(MotionSubspace subspace, double max_distance_m)
      : subspace_(std::move(subspace)), max_distance_m_(max_distance_m) {}

  void estimateRigidTransformation(const SourceCloud& source, const TargetCloud& target,
                                   Matrix4& transform) const override {
    pcl::Indices all(source.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<pcl::index_t>(i);
    estimateRigidTransformation(source, all, target, all, transform);
  }
  void estimateRigidTransformation(const SourceCloud& source, const pcl::Indices& source_indices,
                                   const TargetCloud& target, Matrix4& transform) const override {
    estimateRigidTransformation(source, source_indices, target, source_indices, transform);
  }
  void estimateRigidTransformation(const SourceCloud& source, const pcl::Indices& source_indices,
                                   const TargetCloud& target, const pcl::Indices& target_indices,
                                   Matrix4& transform) const override {
    pcl::Correspondences pairs;
    const std::size_t n = std::min(source_indices.size(), target_indices.size());
    for (std::size_t i = 0; i < n; ++i) pairs.emplace_back(source_indices[i], target_indices[i], 0.0F);
    estimateRigidTransformation(source, target, pairs, transform);
  }
  void estimateRigidTransformation(const SourceCloud& source, const TargetCloud& target,
                                   const pcl::Correspondences& pairs, Matrix4& transform) const override {
    ++calls_;
    Vector6d x = solve_within(point_to_plane_equations(source, target, pairs, max_distance_m_), subspace_);
    // Points changing grid cells can make the steps flip back and forth: each reversal halves the
    // steps, each step on in the same direction doubles them again (up to the full step).
    const bool reversed = x.dot(previous_) < -0.5 * x.norm() * previous_.norm();
    damping_ = reversed ? 0.5 * damping_ : std::min(1.0, 2.0 * damping_);
    previous_ = x;
    // A step is at most 1 degree and 20 mm: far pairs (coarse gate) cannot throw the pass off.
    const double limit = std::min({1.0, kMaxTurn_rad / std::max(1e-12, x.tail<3>().norm()),
                                   kMaxShift_m / std::max(1e-12, x.head<3>().norm())});
    x *= damping_ * limit;
    transform = motion_transform(x).matrix();
  }

  [[nodiscard]] int calls() const { return calls_; }

 private:
  MotionSubspace subspace_;
  double max_distance_m_;
  mutable int calls_ = 0;
  mutable Vector6d previous_ = Vector6d::Zero();
  mutable double damping_ = 1.0;
};

std::shared_ptr<Projection> projection_on(const GridCamera& grid) {
  auto projection = pcl::make_shared<Projection>();
  projection->setFocalLengths(grid.fx, grid.fy);
  projection->setCameraCenters(grid.cx, grid.cy);
  return projection;
}

}  // namespace

void NormalEquations::add(const Eigen::Vector3d& p, const Eigen::Vector3d& n, double residual_m,
                          double weight) {
  Vector6d J;
  J << n, p.cross(n);
  H.selfadjointView<Eigen::Upper>().rankUpdate(J, weight);
  g.noalias() += weight * residual_m * J;
  sum_m_ += p;
  sum_sq_m2_ += p.squaredNorm();
  ++count;
}

void NormalEquations::finish() {
  H = H.selfadjointView<Eigen::Upper>();
  if (count == 0) return;
  const double n = static_cast<double>(count);
  centroid_m = sum_m_ / n;
  extent_m = std::sqrt(std::max(1e-6, sum_sq_m2_ / n - centroid_m.squaredNorm()));
  range_m = std::sqrt(std::max(1e-6, sum_sq_m2_ / n));
}

NormalEquations point_to_plane_equations(const SourceCloud& source, const TargetCloud& target,
                                         const pcl::Correspondences& pairs, double max_distance_m) {
  NormalEquations eq;
  double weighted_sq = 0.0, weight_sum = 0.0;
  for (const pcl::Correspondence& pair : pairs) {
    const pcl::PointNormal& q = target[static_cast<std::size_t>(pair.index_match)];
    const Eigen::Vector3f p = source[static_cast<std::size_t>(pair.index_query)].getVector3fMap();
    const Eigen::Vector3f n = q.getNormalVector3fMap();
    const double r = static_cast<double>(n.dot(p - q.getVector3fMap()));
    // The projective pairs carry their distance; Tukey's biweight of it.
    const double d = static_cast<double>(pair.distance) / max_distance_m;
    const double w = d < 1.0 ? (1.0 - d * d) * (1.0 - d * d) : 0.0;
    eq.add(p.cast<double>(), n.cast<double>(), r, w);
    weighted_sq += w * r * r;
    weight_sum += w;
  }
  eq.finish();
  if (weight_sum > 0.0) eq.rms_m = std::sqrt(weighted_sq / weight_sum);
  return eq;
}

NormalEquations reference_equations(const TargetCloud& target) {
  NormalEquations eq;
  for (const pcl::PointNormal& q : target) {
    if (std::isfinite(q.z))
      eq.add(q.getVector3fMap().cast<double>(), q.getNormalVector3fMap().cast<double>(), 0.0, 1.0);
  }
  eq.finish();
  return eq;
}

IcpPass run_icp_pass(const DriftReference::Data& reference, const SourceCloud::Ptr& source,
                     const Eigen::Isometry3d& T_initial, const IcpSettings& settings) {
  auto step = pcl::make_shared<ObservablePointToPlane>(*settings.subspace, settings.max_correspondence_m);
  pcl::IterativeClosestPoint<pcl::PointNormal, pcl::PointNormal, double> icp;
  icp.setCorrespondenceEstimation(projection_on(reference.grid));
  icp.setTransformationEstimation(step);
  // Correspondences come from the grid: an empty tree that is never built.
  icp.setSearchMethodTarget(pcl::make_shared<pcl::search::KdTree<pcl::PointNormal>>(), true);
  icp.setInputSource(source);
  icp.setInputTarget(reference.target);
  icp.setMaxCorrespondenceDistance(settings.max_correspondence_m);
  icp.setMaximumIterations(settings.max_iterations);
  // A step below both ends the pass (PCL compares the squared shift and the cosine of the turn).
  icp.setTransformationEpsilon(settings.min_step_m * settings.min_step_m);
  icp.setTransformationRotationEpsilon(std::cos(settings.min_step_deg * 3.14159265358979323846 / 180.0));
  SourceCloud aligned;
  icp.align(aligned, T_initial.matrix());
  IcpPass pass;
  pass.iterations = step->calls();
  if (pass.iterations > 0)
    pass.T_reference_camera.matrix() = icp.getFinalTransformation();
  else
    pass.T_reference_camera = T_initial;
  return pass;
}

NormalEquations evaluate_alignment(const DriftReference::Data& reference, const SourceCloud& source,
                                   const Eigen::Isometry3d& T_reference_camera, double max_correspondence_m) {
  auto moved = pcl::make_shared<SourceCloud>();
  pcl::transformPointCloud(source, *moved, T_reference_camera.matrix());
  const std::shared_ptr<Projection> projection = projection_on(reference.grid);
  projection->setInputSource(moved);
  projection->setInputTarget(reference.target);
  pcl::Correspondences pairs;
  projection->determineCorrespondences(pairs, max_correspondence_m);
  return point_to_plane_equations(*moved, *reference.target, pairs, max_correspondence_m);
}

}  // namespace palletd
