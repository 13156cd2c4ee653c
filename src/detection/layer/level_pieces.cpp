// Stage 3b: a plane laid across two levels, refitted on its highest piece (layer_stages.hpp).
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

/// The mask is read at every kStride_px-th pixel in both directions (pieces connected there, their
/// points sampled there).
constexpr int kStride_px = 2;
/// A piece counts with at least this many sampled points (about 0.05 m2 at 2.5 m on VGA).
constexpr std::size_t kMinPiecePoints = 200;

/// One piece of the layer mask: its sampled points and their median height along up [m].
struct Piece {
  std::vector<Eigen::Vector3d> points;
  double height_m = 0.0;
};

std::vector<Piece> pieces_of(const cv::Mat& mask, const OrganizedCloud& cloud, const Eigen::Vector3d& up,
                             const PlaneParams& params) {
  cv::Mat1b sampled((mask.rows + kStride_px - 1) / kStride_px, (mask.cols + kStride_px - 1) / kStride_px);
  for (int r = 0; r < sampled.rows; ++r) {
    for (int c = 0; c < sampled.cols; ++c)
      sampled(r, c) = mask.at<std::uint8_t>(kStride_px * r, kStride_px * c);
  }
  cv::Mat labels;
  const int n = cv::connectedComponents(sampled, labels, 8, CV_32S);
  std::vector<Piece> pieces(static_cast<std::size_t>(std::max(n, 1)));
  for (int r = 0; r < sampled.rows; ++r) {
    for (int c = 0; c < sampled.cols; ++c) {
      const int label = labels.at<std::int32_t>(r, c);
      const Eigen::Vector3f& p = cloud.at(kStride_px * c, kStride_px * r);
      if (label <= 0 || !usable(p, params)) continue;
      pieces[static_cast<std::size_t>(label)].points.push_back(p.cast<double>());
    }
  }
  std::vector<Piece> kept;
  for (Piece& piece : pieces) {
    if (piece.points.size() < kMinPiecePoints) continue;
    std::vector<double> h;
    h.reserve(piece.points.size());
    for (const Eigen::Vector3d& p : piece.points) h.push_back(up.dot(p));
    std::nth_element(h.begin(), h.begin() + static_cast<std::ptrdiff_t>(h.size() / 2), h.end());
    piece.height_m = h[h.size() / 2];
    kept.push_back(std::move(piece));
  }
  return kept;
}

/// Total least-squares plane through the points, its normal on the side of `like`.
Plane plane_through(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& like,
                    Eigen::Vector3d& centroid) {
  centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) cov += (p - centroid) * (p - centroid).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Plane plane;
  plane.normal = eig.eigenvectors().col(0).normalized();
  if (plane.normal.dot(like) < 0.0) plane.normal = -plane.normal;
  plane.d = -plane.normal.dot(centroid);
  return plane;
}

}  // namespace

std::optional<PieceLevel> highest_piece_level(const cv::Mat& mask, const OrganizedCloud& cloud,
                                              const Plane& plane, const Eigen::Vector3d& up_camera,
                                              const PlaneParams& params) {
  const Eigen::Vector3d up = up_camera.normalized();
  const std::vector<Piece> pieces = pieces_of(mask, cloud, up, params);
  if (pieces.size() < 2) return std::nullopt;
  const auto by_height = [](const Piece& a, const Piece& b) { return a.height_m < b.height_m; };
  const Piece& highest = *std::max_element(pieces.begin(), pieces.end(), by_height);
  const Piece& lowest = *std::min_element(pieces.begin(), pieces.end(), by_height);
  if (!(highest.height_m - lowest.height_m > kMaxPieceSpread_m)) return std::nullopt;
  PieceLevel level;
  level.plane = plane_through(highest.points, plane.normal, level.centroid);
  // A piece that is no level itself (a slope, a wall's top edge) is no better than the plane.
  if (std::acos(std::min(1.0, std::abs(level.plane.normal.dot(up)))) >
      params.max_base_tilt_deg * M_PI / 180.0)
    return std::nullopt;
  level.step_m = highest.height_m - lowest.height_m;
  return level;
}

}  // namespace palletd::layer
