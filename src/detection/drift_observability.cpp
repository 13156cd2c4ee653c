// Which motions the fixed geometry constrains (drift_internal.hpp): the eigen directions of the
// point-to-plane information, turns about the points' centroid scaled by their extent.
#include <string>

#include <Eigen/Eigenvalues>

#include "drift_internal.hpp"

namespace palletd {

namespace {

/// x = to_camera * y: y has turns about the centroid, scaled by the extent (a turn about the
/// camera's origin is a turn about the centroid plus a shift).
Matrix6d to_camera_of(const NormalEquations& eq, Pivot pivot) {
  Matrix6d to_camera = Matrix6d::Identity();
  if (pivot == Pivot::kCamera) {
    to_camera.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() / eq.range_m;
    return to_camera;
  }
  const Eigen::Vector3d& c = eq.centroid_m;
  Eigen::Matrix3d c_cross;
  c_cross << 0.0, -c.z(), c.y(), c.z(), 0.0, -c.x(), -c.y(), c.x(), 0.0;
  to_camera.topRightCorner<3, 3>() = c_cross / eq.extent_m;
  to_camera.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() / eq.extent_m;
  return to_camera;
}

/// The eigen directions of the information in y, weakest first, and how many are constrained
/// (the last ones).
struct ScaledInformation {
  Matrix6d to_camera;
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen;
  int constrained = 0;
};

ScaledInformation scaled_information(const NormalEquations& eq, double min_ratio,
                                     Pivot pivot = Pivot::kCentroid) {
  ScaledInformation s;
  s.to_camera = to_camera_of(eq, pivot);
  s.eigen.compute(s.to_camera.transpose() * eq.H * s.to_camera);
  const double largest = s.eigen.eigenvalues()(5);
  for (int k = 0; k < 6; ++k)
    s.constrained += largest > 0.0 && s.eigen.eigenvalues()(k) > min_ratio * largest ? 1 : 0;
  if (eq.count == 0) s.constrained = 0;
  return s;
}

const char* const kAxisNames[6] = {"shift along x", "shift along y", "shift along z",
                                   "turn about x",  "turn about y",  "turn about z"};

std::string note_of(const DriftObservability& o) {
  if (o.dofs == 0) return "the fixed geometry constrains no motion";
  if (o.dofs == 6) return "the fixed geometry constrains all six motions";
  std::string hidden;
  for (int i = 0; i < 6; ++i) {
    if (o.axes[static_cast<std::size_t>(i)]) continue;
    hidden += (hidden.empty() ? "" : ", ") + std::string(kAxisNames[i]);
  }
  if (hidden.empty()) hidden = "combinations of the axes' motions";
  return "the fixed geometry constrains " + std::to_string(o.dofs) +
         " of 6 motions; not measured: " + hidden +
         " (reference camera axes; turns about the fixed points' centroid)";
}

Vector6d motion_vector(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd turn(T.linear());
  Vector6d x;
  x << T.translation(), turn.angle() * turn.axis();
  return x;
}

}  // namespace

MotionSubspace constrained_subspace(const NormalEquations& eq, double min_ratio, Pivot pivot) {
  const ScaledInformation s = scaled_information(eq, min_ratio, pivot);
  MotionSubspace subspace;
  subspace.to_camera = s.to_camera;
  subspace.basis = s.eigen.eigenvectors().rightCols(s.constrained);
  subspace.weak = s.to_camera * s.eigen.eigenvectors().leftCols(6 - s.constrained);
  subspace.range_m = eq.range_m;
  subspace.min_ratio = min_ratio;
  return subspace;
}

Vector6d least_camera_motion(const Vector6d& x, const Eigen::MatrixXd& free, double range_m) {
  if (free.cols() == 0) return x;
  Vector6d metric;
  metric << 1.0, 1.0, 1.0, range_m * range_m, range_m * range_m, range_m * range_m;
  const Eigen::MatrixXd GW = metric.asDiagonal() * free;
  const Eigen::VectorXd a = (free.transpose() * GW).ldlt().solve(GW.transpose() * x);
  return x - free * a;
}

Vector6d solve_within(const NormalEquations& eq, const MotionSubspace& subspace) {
  if (eq.count == 0 || subspace.basis.cols() == 0) return Vector6d::Zero();
  const Eigen::MatrixXd B = subspace.to_camera * subspace.basis;  // the directions, camera coordinates
  const Eigen::MatrixXd H = B.transpose() * eq.H * B;
  const Eigen::VectorXd g = B.transpose() * eq.g;
  // A direction these pairs hardly constrain (thinned points, a part of the cell hidden) is left
  // free with the subspace's weak ones: a step along it would follow the noise.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(H);
  const double largest = eigen.eigenvalues().maxCoeff();
  Eigen::VectorXd z = Eigen::VectorXd::Zero(H.rows());
  Eigen::MatrixXd free(6, subspace.weak.cols() + H.rows());
  free.leftCols(subspace.weak.cols()) = subspace.weak;
  Eigen::Index n_free = subspace.weak.cols();
  for (Eigen::Index k = 0; k < H.rows(); ++k) {
    const double lambda = eigen.eigenvalues()(k);
    if (lambda > subspace.min_ratio * largest && lambda > 0.0)
      z -= eigen.eigenvectors().col(k) * (eigen.eigenvectors().col(k).dot(g) / lambda);
    else
      free.col(n_free++) = B * eigen.eigenvectors().col(k);
  }
  return least_camera_motion(B * z, free.leftCols(n_free), subspace.range_m);
}

Eigen::Isometry3d restrict_to(const Eigen::Isometry3d& T, const MotionSubspace& subspace) {
  return motion_transform(least_camera_motion(motion_vector(T), subspace.weak, subspace.range_m));
}

DriftObservability observability_of(const NormalEquations& eq, double min_ratio) {
  const ScaledInformation s = scaled_information(eq, min_ratio);
  DriftObservability o;
  o.dofs = s.constrained;
  // An axis (a shift, or a turn about the centroid) is measured unless it lies mostly in the span
  // of the weak directions.
  const Vector6d weak_share = s.eigen.eigenvectors().leftCols(6 - s.constrained).rowwise().squaredNorm();
  for (int i = 0; i < 6; ++i) o.axes[static_cast<std::size_t>(i)] = o.dofs > 0 && weak_share(i) < 0.5;
  o.note = note_of(o);
  return o;
}

Eigen::Isometry3d motion_transform(const Vector6d& x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = x.tail<3>();
  const double angle = w.norm();
  if (angle > 0.0) T.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  T.translation() = x.head<3>();
  return T;
}

}  // namespace palletd
