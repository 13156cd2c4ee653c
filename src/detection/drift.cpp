// The camera mount drift (drift.hpp): the reference's fixed geometry from the commissioning frame,
// and a later frame's fixed geometry registered to it in two coarse ICP passes and a fine one.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <pcl/console/print.h>
#include <pcl/features/normal_3d.h>
#include <pcl/search/kdtree.h>

#include "drift_internal.hpp"
#include "frame_problem.hpp"

namespace palletd {

namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;
// A block whose depths spread more than this straddles a depth edge.
constexpr float kBlockEdge_m = 0.10F;
constexpr float kBlockEdgeShare = 0.02F;
// The coarse pass's first stage moves along the directions with at least this share of the
// largest information.
constexpr double kStrongRatio = 0.1;

using CameraCloud = pcl::PointCloud<pcl::PointXYZ>;
using SourceCloud = pcl::PointCloud<pcl::PointNormal>;  // the ICP's source (its normals are not used)

/// The pinhole grid of stride x stride pixel blocks: pixel column u in block column u / stride; the
/// centre's shift 1 / (2 stride) makes the projection's truncation land in the right block.
GridCamera grid_camera(const Intrinsics& k, int stride_px) {
  const auto s = static_cast<float>(stride_px);
  return {(k.width + stride_px - 1) / stride_px,
          (k.height + stride_px - 1) / stride_px,
          static_cast<float>(k.fx) / s,
          static_cast<float>(k.fy) / s,
          static_cast<float>(k.cx) / s + 0.5F / s,
          static_cast<float>(k.cy) / s + 0.5F / s};
}

/// A block's points, or nothing when they straddle a depth edge (mixed pixels, two surfaces).
struct Block {
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  float z_min = std::numeric_limits<float>::infinity(), z_max = 0.0F;
  int count = 0;

  void add(const Eigen::Vector3f& p) {
    sum += p;
    z_min = std::min(z_min, p.z());
    z_max = std::max(z_max, p.z());
    ++count;
  }
  [[nodiscard]] bool usable() const {
    return count > 0 && z_max - z_min < kBlockEdge_m + kBlockEdgeShare * z_min;
  }
};

/// The mean point of each stride x stride block of pixels, organized, camera frame [m]; NaN where
/// the block has no depth or straddles a depth edge. Averaging lowers the noise, and a block is
/// seldom without depth, so that the normals' windows do not stop at every dropped pixel.
CameraCloud::Ptr block_cloud(const Frame& frame, const RayTable& rays, int stride_px) {
  const int width = frame.intrinsics.width, height = frame.intrinsics.height;
  const GridCamera grid = grid_camera(frame.intrinsics, stride_px);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  auto cloud = pcl::make_shared<CameraCloud>(grid.width, grid.height, pcl::PointXYZ(nan, nan, nan));
  cloud->is_dense = false;
  for (int bv = 0; bv < grid.height; ++bv) {
    for (int bu = 0; bu < grid.width; ++bu) {
      Block block;
      for (int v = bv * stride_px; v < std::min(height, (bv + 1) * stride_px); ++v) {
        for (int u = bu * stride_px; u < std::min(width, (bu + 1) * stride_px); ++u) {
          const std::size_t i =
              static_cast<std::size_t>(v) * static_cast<std::size_t>(width) + static_cast<std::size_t>(u);
          const float z = frame.depth_m(i);
          if (std::isfinite(z)) block.add(Eigen::Vector3f(rays.ray(i).x() * z, rays.ray(i).y() * z, z));
        }
      }
      if (block.usable()) cloud->at(bu, bv).getVector3fMap() = block.sum / static_cast<float>(block.count);
    }
  }
  return cloud;
}

/// The block points outside the footprint in the reference (unorganized).
CameraCloud::Ptr fixed_candidates(const CameraCloud& cloud, const DriftReference::Data& data) {
  auto out = pcl::make_shared<CameraCloud>();
  for (const pcl::PointXYZ& p : cloud) {
    if (std::isfinite(p.z) && p.z > 0.0F &&
        outside_footprint(data.roi, data.footprint_margin_m,
                          data.T_roi_camera * p.getVector3fMap().cast<double>()))
      out->push_back(p);
  }
  return out;
}

/// Normals (PCL: the plane through each point's nearest neighbours, found in a kd-tree), toward
/// the camera. A missing block does not shrink the neighbourhood as it would an image window.
pcl::PointCloud<pcl::Normal> normals_of(const CameraCloud::Ptr& points, int neighbours) {
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
  estimation.setInputCloud(points);
  estimation.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  estimation.setKSearch(neighbours);
  estimation.setViewPoint(0.0F, 0.0F, 0.0F);
  pcl::PointCloud<pcl::Normal> normals;
  estimation.compute(normals);
  return normals;
}

/// The fixed points with finite normals on the pinhole grid (the nearest where two land on one cell).
std::size_t place_on_grid(const CameraCloud& points, const pcl::PointCloud<pcl::Normal>& normals,
                          DriftReference::Data& data) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const GridCamera& g = data.grid;
  pcl::PointNormal empty;
  empty.x = empty.y = empty.z = nan;
  data.target = pcl::make_shared<pcl::PointCloud<pcl::PointNormal>>(g.width, g.height, empty);
  data.target->is_dense = false;
  std::size_t placed = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f p = points[i].getVector3fMap();
    const Eigen::Vector3f n = normals[i].getNormalVector3fMap();
    if (!n.allFinite()) continue;
    const float col = g.fx * p.x() / p.z() + g.cx, row = g.fy * p.y() / p.z() + g.cy;
    if (!(col >= 0.0F && row >= 0.0F && col < static_cast<float>(g.width) &&
          row < static_cast<float>(g.height)))
      continue;
    pcl::PointNormal& cell = data.target->at(static_cast<int>(col), static_cast<int>(row));
    if (std::isfinite(cell.z) && cell.z <= p.z()) continue;
    placed += std::isfinite(cell.z) ? 0U : 1U;
    cell.getVector3fMap() = p;
    cell.getNormalVector3fMap() = n;
  }
  return placed;
}

/// The points of `cloud` outside the footprint with the camera at T_roi_camera, thinned to at
/// most `max_points` (every k-th).
SourceCloud::Ptr fixed_points(const CameraCloud& cloud, const DriftReference::Data& reference,
                              const Eigen::Isometry3d& T_roi_camera, double margin_m,
                              std::size_t max_points) {
  std::vector<std::size_t> fixed;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (std::isfinite(cloud[i].z) &&
        outside_footprint(reference.roi, margin_m, T_roi_camera * cloud[i].getVector3fMap().cast<double>()))
      fixed.push_back(i);
  }
  const std::size_t step =
      std::max<std::size_t>(1, (fixed.size() + max_points - 1) / std::max<std::size_t>(1, max_points));
  auto out = pcl::make_shared<SourceCloud>();
  out->reserve(fixed.size() / step + 1);
  for (std::size_t k = 0; k < fixed.size(); k += step) {
    pcl::PointNormal q;
    q.getVector3fMap() = cloud[fixed[k]].getVector3fMap();
    q.getNormalVector3fMap().setZero();
    out->push_back(q);
  }
  return out;
}

DriftEstimate not_measured(std::string message) {
  DriftEstimate estimate;
  estimate.message = std::move(message);
  return estimate;
}

/// The three ICP passes and the fine pass's source points (null, with the reason, when the frame
/// shows too little of the cell).
struct Registration {
  Eigen::Isometry3d T_reference_camera = Eigen::Isometry3d::Identity();
  SourceCloud::Ptr source;
  int iterations = 0;
  std::string problem;
};

Registration register_frame(const CameraCloud& cloud, const DriftReference::Data& ref,
                            const DriftParams& params) {
  Registration out;
  // Coarse: the load placed as in the reference with the footprint grown for the unknown drift; the
  // best constrained directions first (with turns about the camera: the floor's tilt and height),
  // then all of them.
  const SourceCloud::Ptr coarse_source =
      fixed_points(cloud, ref, ref.T_roi_camera, params.footprint_margin_m + params.coarse_margin_m,
                   params.max_points / 4);
  if (coarse_source->size() < params.min_points / 4) {
    out.problem = "the frame shows " + std::to_string(coarse_source->size()) +
                  " fixed points beside the load: the cell is hidden or out of view";
    return out;
  }
  const IcpSettings coarse{nullptr, params.coarse_correspondence_m, params.coarse_iterations, 5e-4, 0.02};
  IcpSettings strong = coarse;
  strong.subspace = &ref.strong_subspace;
  const IcpPass first = run_icp_pass(ref, coarse_source, Eigen::Isometry3d::Identity(), strong);
  IcpSettings all = coarse;
  all.subspace = &ref.subspace;
  const IcpPass second = run_icp_pass(ref, coarse_source, first.T_reference_camera, all);
  // Fine: the load placed with the coarse drift, all fixed points (thinned to max_points).
  out.source = fixed_points(cloud, ref, ref.T_roi_camera * second.T_reference_camera,
                            params.footprint_margin_m, params.max_points);
  const IcpSettings fine{&ref.subspace, params.max_correspondence_m, params.max_iterations, 1e-4, 0.005};
  const IcpPass third = run_icp_pass(ref, out.source, second.T_reference_camera, fine);
  out.T_reference_camera = third.T_reference_camera;
  out.iterations = first.iterations + second.iterations + third.iterations;
  return out;
}

/// The estimate from the registration and its pairs at the end.
DriftEstimate report(const Registration& registration, const NormalEquations& eq, const DriftParams& params) {
  DriftEstimate estimate;
  estimate.points = eq.count;
  estimate.matched_share = static_cast<double>(eq.count) /
                           static_cast<double>(std::max<std::size_t>(1, registration.source->size()));
  estimate.iterations = registration.iterations;
  estimate.rms_mm = eq.rms_m * 1000.0;
  estimate.observability = observability_of(eq, params.min_information_ratio);
  const std::string matched = std::to_string(eq.count) + " of the frame's " +
                              std::to_string(registration.source->size()) +
                              " fixed points match the reference";
  if (eq.count < params.min_points)
    estimate.message = "only " + matched + " (at least " + std::to_string(params.min_points) +
                       "): the cell is hidden, changed since the reference, or the camera moved too far";
  else if (estimate.matched_share < params.min_matched_share)
    estimate.message =
        "only " + matched + ": the registration failed (the camera moved too far) or the cell changed";
  else if (estimate.observability.dofs == 0)
    estimate.message = "the fixed points in view constrain no motion of the camera";
  if (!estimate.message.empty()) return estimate;
  // Left out: what the coarse passes moved along a direction these pairs do not constrain.
  estimate.measured = true;
  estimate.T_reference_camera =
      restrict_to(registration.T_reference_camera, constrained_subspace(eq, params.min_information_ratio));
  estimate.shift_mm = estimate.T_reference_camera.translation().norm() * 1000.0;
  estimate.angle_deg = Eigen::AngleAxisd(estimate.T_reference_camera.linear()).angle() * kRadToDeg;
  return estimate;
}

}  // namespace

bool outside_footprint(const RegionOfInterest& roi, double margin_m, const Eigen::Vector3d& p_roi) {
  return p_roi.x() < roi.min_m.x() - margin_m || p_roi.x() > roi.max_m.x() + margin_m ||
         p_roi.y() < roi.min_m.y() - margin_m || p_roi.y() > roi.max_m.y() + margin_m;
}

std::size_t DriftReference::points() const { return data_ ? data_->points : 0; }

const DriftObservability& DriftReference::observability() const {
  static const DriftObservability kNone{{}, 0, "no reference"};
  return data_ ? data_->observability : kNone;
}

Expected<DriftReference> DriftReference::from_frame(const Frame& frame,
                                                    const std::optional<RegionOfInterest>& roi,
                                                    const DriftParams& params) {
  if (!roi)
    return Error{
        "no region of interest (detection.roi): without the load volume the cell's fixed geometry "
        "cannot be told from the load, so the camera's drift is not measured"};
  if (const std::string problem = frame_problem(frame); !problem.empty()) return Error{problem};
  const bool in_base = roi->frame == RegionOfInterest::Frame::kBase;
  if (in_base && !frame.T_base_camera)
    return Error{
        "the region of interest is in the base frame, but the reference frame has no camera_to_base"};
  // PCL prints its warnings to stderr; detection does not log (its result says what failed).
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  auto data = std::make_shared<Data>();
  data->rays = RayTable(frame.intrinsics);
  data->stride_px = std::max(1, params.stride_px);
  data->roi = *roi;
  data->T_roi_camera = in_base ? *frame.T_base_camera : Eigen::Isometry3d::Identity();
  data->footprint_margin_m = params.footprint_margin_m;
  const CameraCloud::Ptr cloud = block_cloud(frame, data->rays, data->stride_px);
  data->grid = grid_camera(frame.intrinsics, data->stride_px);
  const CameraCloud::Ptr candidates = fixed_candidates(*cloud, *data);
  data->points = place_on_grid(*candidates, normals_of(candidates, params.normal_neighbours), *data);
  if (data->points < params.min_points)
    return Error{"the reference frame shows " + std::to_string(data->points) +
                 " fixed points beside the load (region of interest grown by " +
                 std::to_string(static_cast<int>(std::lround(params.footprint_margin_m * 1000.0))) +
                 " mm), fewer than " + std::to_string(params.min_points) +
                 ": too little of the cell is in view to measure the drift"};
  const NormalEquations information = reference_equations(*data->target);
  data->subspace = constrained_subspace(information, params.min_information_ratio);
  data->strong_subspace =
      constrained_subspace(information, std::max(params.min_information_ratio, kStrongRatio), Pivot::kCamera);
  data->observability = observability_of(information, params.min_information_ratio);
  return DriftReference(std::move(data));
}

DriftEstimate measure_drift(const Frame& frame, const DriftReference& reference, const DriftParams& params) {
  const DriftReference::Data* ref = reference.data_.get();
  if (ref == nullptr) return not_measured("no drift reference (take one from a commissioning frame)");
  if (const std::string problem = frame_problem(frame); !problem.empty()) return not_measured(problem);
  if (!ref->rays.matches(frame.intrinsics))
    return not_measured(
        "the frame's intrinsics differ from the reference's (another camera or mode): take a new reference");
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  const CameraCloud::Ptr cloud = block_cloud(frame, ref->rays, ref->stride_px);
  const Registration registration = register_frame(*cloud, *ref, params);
  if (!registration.source) return not_measured(registration.problem);
  const NormalEquations eq = evaluate_alignment(*ref, *registration.source, registration.T_reference_camera,
                                                params.max_correspondence_m);
  return report(registration, eq, params);
}

}  // namespace palletd
