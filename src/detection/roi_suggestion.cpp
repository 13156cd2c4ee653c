// A region of interest suggested from one frame (roi_suggestion.hpp): floor level, occupancy grid
// of what stands on the floor, the pallet's blob, its bounding box.
#include "palletd/detection/roi_suggestion.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <Eigen/Eigenvalues>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace palletd {

namespace {

constexpr double kHistogramBin_m = 0.01;
constexpr double kFloorMinShare = 0.02;  // the floor level holds at least this share of the points
constexpr double kMaxReach_m = 6.0;      // the grid reaches at most this far from the seed

using Points = std::vector<Eigen::Vector3d>;

/// Whether pixel (u, v) lies on a depth edge: a 4-neighbour's depth differs by more than 5 cm + 2 %.
/// Mixed ("flying") pixels between a box's top edge and the floor lie along the viewing ray, up to
/// a dozen cm outside the load's footprint; they and the edge pixels beside them are left out.
bool on_depth_edge(const OrganizedCloud& cloud, int u, int v) {
  const float z = cloud.at(u, v).z();
  const float tolerance_m = 0.05F + 0.02F * z;
  const int du[4] = {1, -1, 0, 0}, dv[4] = {0, 0, 1, -1};
  for (int k = 0; k < 4; ++k) {
    const int nu = u + du[k], nv = v + dv[k];
    if (nu < 0 || nv < 0 || nu >= cloud.width || nv >= cloud.height) continue;
    const float nz = cloud.at(nu, nv).z();
    if (std::isfinite(nz) && std::abs(nz - z) > tolerance_m) return true;
  }
  return false;
}

/// The frame's points, depth edges left out, in the plan frame [m].
Points points_in(const Frame& frame, const Eigen::Isometry3d& T_plan_camera) {
  const RayTable rays(frame.intrinsics);
  OrganizedCloud cloud;
  to_organized_cloud(frame, rays, cloud);
  Points out;
  out.reserve(cloud.points.size());
  for (int v = 0; v < cloud.height; ++v) {
    for (int u = 0; u < cloud.width; ++u) {
      const Eigen::Vector3f& p = cloud.at(u, v);
      if (p.allFinite() && !on_depth_edge(cloud, u, v)) out.push_back(T_plan_camera * p.cast<double>());
    }
  }
  return out;
}

/// Points within `tolerance_m` of the plane through `a` with unit normal `n`.
std::size_t count_inliers(const Points& points, const Eigen::Vector3d& a, const Eigen::Vector3d& n,
                          double tolerance_m) {
  std::size_t count = 0;
  for (const Eigen::Vector3d& p : points) count += std::abs(n.dot(p - a)) < tolerance_m ? 1U : 0U;
  return count;
}

/// Without a calibration, up in the camera frame: the normal, facing the camera, of the largest
/// plane (RANSAC) among the farther half of the points, where the floor is; the reversed optical
/// axis when no plane within 60 deg of it is found.
Eigen::Vector3d floor_normal_camera(Points points) {
  const Eigen::Vector3d straight_down_up = -Eigen::Vector3d::UnitZ();
  if (points.size() < 100) return straight_down_up;
  const auto mid = points.begin() + static_cast<std::ptrdiff_t>(points.size() / 2);
  std::nth_element(points.begin(), mid, points.end(),
                   [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.z() < b.z(); });
  Points sample;
  const std::size_t step = std::max<std::size_t>(1, (points.size() / 2) / 4000);
  for (std::size_t i = points.size() / 2; i < points.size(); i += step) sample.push_back(points[i]);
  constexpr double kInlier_m = 0.02;
  std::mt19937 rng(1);  // deterministic: the same frame gives the same suggestion
  std::uniform_int_distribution<std::size_t> pick(0, sample.size() - 1);
  Eigen::Vector3d best_n = straight_down_up, best_a = Eigen::Vector3d::Zero();
  std::size_t best_count = 0;
  for (int iteration = 0; iteration < 300; ++iteration) {
    const Eigen::Vector3d& a = sample[pick(rng)];
    Eigen::Vector3d n = (sample[pick(rng)] - a).cross(sample[pick(rng)] - a);
    if (n.norm() < 1e-9) continue;
    n.normalize();
    if (n.z() > 0.0) n = -n;
    if (-n.z() < 0.5) continue;  // more than 60 deg from the optical axis: not the floor below
    const std::size_t count = count_inliers(sample, a, n, kInlier_m);
    if (count > best_count) {
      best_count = count;
      best_n = n;
      best_a = a;
    }
  }
  if (best_count < 3) return straight_down_up;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Points inliers;
  for (const Eigen::Vector3d& p : sample) {
    if (std::abs(best_n.dot(p - best_a)) >= kInlier_m) continue;
    inliers.push_back(p);
    centroid += p;
  }
  centroid /= static_cast<double>(inliers.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : inliers) scatter += (p - centroid) * (p - centroid).transpose();
  Eigen::Vector3d n = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(0);
  return n.z() > 0.0 ? Eigen::Vector3d(-n) : n;
}

/// The camera -> plan transform without a calibration: a rotation whose z is `up_camera` and whose
/// x follows the camera's x; its x-y plane is parallel to the floor.
Eigen::Isometry3d plan_from_up(const Eigen::Vector3d& up_camera) {
  const Eigen::Vector3d z = up_camera.normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - z.x() * z;
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - z.y() * z;
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().row(0) = x.transpose();
  T.linear().row(1) = y.transpose();
  T.linear().row(2) = z.transpose();
  return T;
}

/// The lowest large level of the height histogram: the first (from below) 3-bin window holding
/// kFloorMinShare of the points, followed up to its peak, refined to the mean height around it.
std::optional<double> floor_level_m(const Points& points) {
  if (points.empty()) return std::nullopt;
  double lo = points.front().z(), hi = lo;
  for (const Eigen::Vector3d& p : points) {
    lo = std::min(lo, p.z());
    hi = std::max(hi, p.z());
  }
  hi = std::min(hi, lo + 20.0);
  const auto bins = static_cast<std::size_t>((hi - lo) / kHistogramBin_m) + 3;
  std::vector<std::size_t> histogram(bins, 0);
  for (const Eigen::Vector3d& p : points) {
    if (p.z() <= hi) ++histogram[static_cast<std::size_t>((p.z() - lo) / kHistogramBin_m) + 1];
  }
  auto window = [&](std::size_t i) { return histogram[i - 1] + histogram[i] + histogram[i + 1]; };
  const double threshold = std::max(kFloorMinShare * static_cast<double>(points.size()), 30.0);
  std::size_t i = 1;
  while (i + 1 < bins && static_cast<double>(window(i)) < threshold) ++i;
  if (i + 1 >= bins) return std::nullopt;
  while (i + 2 < bins && window(i + 1) > window(i)) ++i;
  const double centre_m = lo + (static_cast<double>(i) - 0.5) * kHistogramBin_m;
  double sum_m = 0.0;
  std::size_t count = 0;
  for (const Eigen::Vector3d& p : points) {
    if (std::abs(p.z() - centre_m) > 1.5 * kHistogramBin_m) continue;
    sum_m += p.z();
    ++count;
  }
  return sum_m / static_cast<double>(count);
}

/// The occupancy grid over the plan frame's x-y: cell (col, row) covers origin + cell * [col, row].
struct HeightGrid {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  double cell_m = 0.01;
  int cols = 0, rows = 0;

  [[nodiscard]] bool cell_of(const Eigen::Vector3d& p, cv::Point& cell) const {
    cell.x = static_cast<int>(std::floor((p.x() - origin_m.x()) / cell_m));
    cell.y = static_cast<int>(std::floor((p.y() - origin_m.y()) / cell_m));
    return cell.x >= 0 && cell.y >= 0 && cell.x < cols && cell.y < rows;
  }
  [[nodiscard]] Eigen::Vector2d corner_m(double col, double row) const {
    return origin_m + cell_m * Eigen::Vector2d(col, row);
  }
};

HeightGrid make_grid(const Points& standing, const Eigen::Vector2d& seed_m, double cell_m) {
  Eigen::Vector2d lo = seed_m, hi = seed_m;
  for (const Eigen::Vector3d& p : standing) {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  const Eigen::Vector2d reach = Eigen::Vector2d::Constant(kMaxReach_m);
  lo = lo.cwiseMax(seed_m - reach) - Eigen::Vector2d::Constant(cell_m);
  hi = hi.cwiseMin(seed_m + reach) + Eigen::Vector2d::Constant(cell_m);
  HeightGrid g;
  g.origin_m = lo;
  g.cell_m = cell_m;
  g.cols = static_cast<int>(std::ceil((hi.x() - lo.x()) / cell_m)) + 1;
  g.rows = static_cast<int>(std::ceil((hi.y() - lo.y()) / cell_m)) + 1;
  return g;
}

/// 255 where a point at most `max_z_m` high falls.
cv::Mat occupancy(const HeightGrid& grid, const Points& standing, double max_z_m) {
  cv::Mat occupied(grid.rows, grid.cols, CV_8UC1, cv::Scalar(0));
  cv::Point c;
  for (const Eigen::Vector3d& p : standing) {
    if (p.z() <= max_z_m && grid.cell_of(p, c)) occupied.at<std::uint8_t>(c) = 255;
  }
  return occupied;
}

cv::Mat square(int gap_cells) {
  return cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * gap_cells + 1, 2 * gap_cells + 1));
}

/// Blob labels of the occupied cells; cells up to `gap_cells` apart join (sparse samples far from
/// the camera). Only occupied cells carry a label.
cv::Mat blob_labels(const cv::Mat& occupied, int gap_cells) {
  cv::Mat joined, labels;
  cv::dilate(occupied, joined, square(gap_cells));
  cv::connectedComponents(joined, labels, 8, CV_32S);
  labels.setTo(0, occupied == 0);
  return labels;
}

/// The label of the blob holding `seed`, else of the labelled cell nearest to it (0: none);
/// `at` becomes that cell.
int blob_at(const cv::Mat& labels, const cv::Point seed, cv::Point& at) {
  const cv::Rect inside(0, 0, labels.cols, labels.rows);
  if (inside.contains(seed) && labels.at<int>(seed) != 0) {
    at = seed;
    return labels.at<int>(seed);
  }
  long best = -1;
  for (int r = 0; r < labels.rows; ++r) {
    const int* row = labels.ptr<int>(r);
    for (int c = 0; c < labels.cols; ++c) {
      if (row[c] == 0) continue;
      const long d =
          static_cast<long>(c - seed.x) * (c - seed.x) + static_cast<long>(r - seed.y) * (r - seed.y);
      if (best >= 0 && d >= best) continue;
      best = d;
      at = cv::Point(c, r);
    }
  }
  return best < 0 ? 0 : labels.at<int>(at);
}

/// The most frequent height (2 cm bins, the bin's mean): the largest level among `z`.
double main_level_m(const std::vector<double>& z) {
  if (z.empty()) return 0.0;
  constexpr double kBin_m = 0.02;
  const double lo = *std::min_element(z.begin(), z.end());
  std::vector<std::size_t> count;
  for (double h : z) {
    const auto i = static_cast<std::size_t>((h - lo) / kBin_m);
    if (i >= count.size()) count.resize(i + 1, 0);
    ++count[i];
  }
  const auto peak = static_cast<double>(std::max_element(count.begin(), count.end()) - count.begin());
  double sum_m = 0.0;
  std::size_t n = 0;
  for (double h : z) {
    if (std::floor((h - lo) / kBin_m) != peak) continue;
    sum_m += h;
    ++n;
  }
  return sum_m / static_cast<double>(n);
}

double percentile(std::vector<double> values, double share) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(share * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

/// Heights of the points whose cell is set in `mask`, at most `max_z_m` high; with `centre` and
/// radius_cells > 0 only those of cells that close to it.
std::vector<double> heights_in(const Points& standing, const HeightGrid& grid, const cv::Mat& mask,
                               double max_z_m, const cv::Point& centre = {}, double radius_cells = 0.0) {
  std::vector<double> z;
  cv::Point c;
  for (const Eigen::Vector3d& p : standing) {
    if (p.z() > max_z_m || !grid.cell_of(p, c) || mask.at<std::uint8_t>(c) == 0) continue;
    if (radius_cells > 0.0 && std::hypot(c.x - centre.x, c.y - centre.y) > radius_cells) continue;
    z.push_back(p.z());
  }
  return z;
}

/// Blobs of `occupied` outside `footprint` at least `min_cells` large: the objects left out.
int count_other_objects(const cv::Mat& occupied, const cv::Mat& footprint, int gap_cells, int min_cells) {
  cv::Mat rest = occupied.clone();
  rest.setTo(0, footprint);
  const cv::Mat labels = blob_labels(rest, gap_cells);
  double most = 0.0;
  cv::minMaxLoc(labels, nullptr, &most);
  std::vector<int> cells(static_cast<std::size_t>(most) + 1, 0);
  for (int r = 0; r < labels.rows; ++r) {
    for (int c = 0; c < labels.cols; ++c) ++cells[static_cast<std::size_t>(labels.at<int>(r, c))];
  }
  return static_cast<int>(
      std::count_if(cells.begin() + 1, cells.end(), [&](int n) { return n >= min_cells; }));
}

/// The footprint's outline in plan x-y: the largest outer contour of the closed mask, simplified.
Ring2d outline_m(const HeightGrid& grid, const cv::Mat& footprint, int gap_cells) {
  cv::Mat closed;
  cv::morphologyEx(footprint, closed, cv::MORPH_CLOSE, square(gap_cells));
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(closed, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  if (contours.empty()) return {};
  const auto largest = std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
    return cv::contourArea(a) < cv::contourArea(b);
  });
  std::vector<cv::Point> simple;
  cv::approxPolyDP(*largest, simple, 1.5, true);
  Ring2d ring;
  for (const cv::Point& q : simple) ring.push_back(grid.corner_m(q.x + 0.5, q.y + 0.5));
  return ring;
}

/// Where the optical axis meets the floor; the centroid of what stands on it when the camera
/// looks up or sideways.
Eigen::Vector2d seed_m(const Eigen::Isometry3d& T_plan_camera, double floor_z_m, const Points& standing) {
  const Eigen::Vector3d origin = T_plan_camera.translation();
  const Eigen::Vector3d axis = T_plan_camera.linear().col(2);
  if (axis.z() < -0.1) return (origin + axis * ((floor_z_m - origin.z()) / axis.z())).head<2>();
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3d& p : standing) sum += p.head<2>();
  return sum / static_cast<double>(std::max<std::size_t>(1, standing.size()));
}

/// Finds the footprint and the load's top (fills footprint_m, footprint_size_m, load_top_z_m,
/// excluded_objects and the region's x-y); false with `message` set when nothing stands there.
bool find_footprint(const Points& points, const Frame& frame, const RoiSuggestionOptions& o,
                    RoiSuggestion& s) {
  Points standing;
  for (const Eigen::Vector3d& p : points) {
    if (p.z() > s.floor_z_m + o.load_min_height_m) standing.push_back(p);
  }
  if (standing.size() < 50) {
    s.message = "nothing stands on the floor (the lowest large level): is the pallet in view?";
    return false;
  }
  const Eigen::Vector2d seed = seed_m(s.T_plan_camera, s.floor_z_m, standing);
  const HeightGrid grid = make_grid(standing, seed, o.cell_m);
  const double range_m =
      (Eigen::Vector3d(seed.x(), seed.y(), s.floor_z_m) - s.T_plan_camera.translation()).norm();
  const int gap =
      std::clamp(static_cast<int>(std::ceil(1.5 * range_m / frame.intrinsics.fx / o.cell_m)), 1, 5);
  cv::Point seed_cell;
  // Outside the grid too: blob_at() then takes the blob nearest to it.
  static_cast<void>(grid.cell_of(Eigen::Vector3d(seed.x(), seed.y(), 0.0), seed_cell));

  // Pass 1: everything that stands on the floor; the stack's top: the largest level of its blob
  // near the seed (the 90th percentile there would be a tall neighbour's top within reach).
  const cv::Mat all = occupancy(grid, standing, 1e9);
  const cv::Mat labels_all = blob_labels(all, gap);
  cv::Point at;
  const int blob = blob_at(labels_all, seed_cell, at);
  if (blob == 0) {
    s.message = "nothing stands on the floor near the optical axis";
    return false;
  }
  const double radius_cells = o.top_search_radius_m / o.cell_m;
  const double top_near_m =
      main_level_m(heights_in(standing, grid, labels_all == blob, 1e9, at, radius_cells));
  // Pass 2: without what stands far above that top (a cabinet touching the pallet).
  const double max_z_m = top_near_m + o.tall_step_m;
  const cv::Mat low = occupancy(grid, standing, max_z_m);
  const cv::Mat labels_low = blob_labels(low, gap);
  const cv::Mat footprint = labels_low == blob_at(labels_low, at, at);

  cv::Mat inner;
  cv::erode(footprint, inner, square(2));
  s.load_top_z_m =
      percentile(heights_in(standing, grid, cv::countNonZero(inner) > 0 ? inner : footprint, max_z_m), 0.98);
  const int min_cells = static_cast<int>(std::ceil(o.min_object_area_m2 / (o.cell_m * o.cell_m)));
  s.excluded_objects = count_other_objects(all, footprint, gap, min_cells);
  s.footprint_m = outline_m(grid, footprint, gap);
  const cv::Rect box = cv::boundingRect(footprint);
  const Eigen::Vector2d lo = grid.corner_m(box.x, box.y),
                        hi = grid.corner_m(box.x + box.width, box.y + box.height);
  s.footprint_size_m = hi - lo;
  s.roi.min_m.head<2>() = lo - Eigen::Vector2d::Constant(o.margin_m);
  s.roi.max_m.head<2>() = hi + Eigen::Vector2d::Constant(o.margin_m);
  return true;
}

/// The axis-aligned camera-frame box around a plan-frame box (its eight corners).
RegionOfInterest to_camera(const RegionOfInterest& plan, const Eigen::Isometry3d& T_camera_plan) {
  RegionOfInterest out;
  out.frame = RegionOfInterest::Frame::kCamera;
  out.min_m = Eigen::Vector3d::Constant(1e9);
  out.max_m = Eigen::Vector3d::Constant(-1e9);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner((i & 1) != 0 ? plan.max_m.x() : plan.min_m.x(),
                                 (i & 2) != 0 ? plan.max_m.y() : plan.min_m.y(),
                                 (i & 4) != 0 ? plan.max_m.z() : plan.min_m.z());
    const Eigen::Vector3d p = T_camera_plan * corner;
    out.min_m = out.min_m.cwiseMin(p);
    out.max_m = out.max_m.cwiseMax(p);
  }
  return out;
}

std::string summary(const RoiSuggestion& s, const std::string& note) {
  char line[256];
  std::snprintf(line, sizeof line,
                "footprint %.2f x %.2f m, load top %.2f m above the floor (floor at z = %.3f m)",
                s.footprint_size_m.x(), s.footprint_size_m.y(), s.load_top_z_m - s.floor_z_m, s.floor_z_m);
  std::string text = line;
  text += "; " + std::to_string(s.excluded_objects) + (s.excluded_objects == 1 ? " object" : " objects") +
          " beside the pallet left out";
  if (!note.empty()) text += "; " + note;
  if (s.camera_fallback)
    text += "; no camera_to_base: region in the camera frame (up taken from the floor plane)";
  return text;
}

}  // namespace

RoiSuggestion suggest_region_of_interest(const Frame& frame,
                                         const std::optional<Eigen::Isometry3d>& T_base_camera,
                                         const RoiSuggestionOptions& options) {
  RoiSuggestion s;
  if (!frame.intrinsics.valid() || frame.depth.size() != frame.pixel_count()) {
    s.message = "the frame has no valid intrinsics or depth image";
    return s;
  }
  s.camera_fallback = options.frame == RegionOfInterest::Frame::kBase && !T_base_camera;
  s.T_plan_camera = T_base_camera
                        ? *T_base_camera
                        : plan_from_up(floor_normal_camera(points_in(frame, Eigen::Isometry3d::Identity())));
  const Points points = points_in(frame, s.T_plan_camera);
  const std::optional<double> floor_z_m = floor_level_m(points);
  if (!floor_z_m) {
    s.message = "no large level in the height histogram: no floor in view";
    return s;
  }
  s.floor_z_m = *floor_z_m;
  if (!find_footprint(points, frame, options, s)) return s;

  std::string note;
  s.roi.min_m.z() = s.floor_z_m + options.floor_clearance_m;
  s.roi.max_m.z() = s.load_top_z_m + options.above_m;
  if (options.max_load_height_m) {
    const double full_m = s.floor_z_m + *options.max_load_height_m;
    if (full_m > s.load_top_z_m + 0.05)
      s.roi.max_m.z() = full_m;
    else
      note = "the maximum load height is not above the load's top: z max = top + above instead";
  }
  const bool in_base = T_base_camera && options.frame == RegionOfInterest::Frame::kBase;
  s.roi.frame = RegionOfInterest::Frame::kBase;
  if (!in_base) s.roi = to_camera(s.roi, s.T_plan_camera.inverse());
  s.ok = true;
  s.message = summary(s, note);
  return s;
}

}  // namespace palletd
