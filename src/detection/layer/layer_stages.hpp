// The stages of extract_layer(), each a function of values in and values out (private header;
// the tests include it to check each stage alone).
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "palletd/core/frame.hpp"
#include "palletd/core/geometry.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd::layer {

// ---- physical limits --------------------------------------------------------------------------

/// A box layer below the top one is at least this much lower (boxes are >= 100 mm high) [m].
constexpr double kMinLayerStep = 0.10;
/// Widest passthrough / refit band: half the step to the layer below [m].
constexpr double kMaxBand = 0.5 * kMinLayerStep;
/// What the passthrough band adds to the depth noise: boxes whose heights differ as built [m].
constexpr double kBandMargin_m = 0.004;

// ---- stage 1: top plane ----------------------------------------------------------------------

/// Depth noise of the plane's points, measured (robust sigma of the residuals per depth bin).
struct DepthNoise {
  std::vector<double> bin_z_m;      ///< bin centres (median depth), ascending [m]; empty: one sigma
  std::vector<double> bin_sigma_m;  ///< robust sigma per bin [m]
  double sigma_all_m = 0.0;     ///< robust sigma of all points [m]
  /// The step between the depths the sensor can report, over depth squared [1/m]: structured
  /// light and stereo measure a disparity in sub-pixel steps, so their depths come in levels
  /// z^2 / (f b) per step apart (8-20 mm at 1.7-2.7 m on a Kinect-like camera); a time-of-flight
  /// camera's depth unit is a fraction of its noise. The median gap between the distinct depths
  /// measured near the plane, over the depth squared.
  double step_per_z2 = 0.0;
  /// Sigma at depth z, linear between bin centres, constant beyond [m].
  [[nodiscard]] double sigma_at(double z_m) const;
  /// The step between reported depths at depth z [m].
  [[nodiscard]] double step_at(double z_m) const { return step_per_z2 * z_m * z_m; }
  /// Passthrough band at depth z [m]: default_passthrough_tolerance of sigma_at, and at least one
  /// depth step beyond the same margin (a plane between two levels is measured on both; a bin's
  /// sigma depends on where the plane falls between them and may be far less than a step).
  [[nodiscard]] double band_at(double z_m) const;
};

struct TopPlane {
  DetectionStatus status = DetectionStatus::kNoPlane;
  std::string reason;
  Plane plane;                 ///< refitted, normal toward the camera
  double sigma_m = 0.0;        ///< robust sigma of the residuals near the plane [m]
  DepthNoise noise;            ///< the same per depth
  std::size_t valid_points = 0;
  std::size_t inliers = 0;     ///< full-resolution refit inliers
  std::size_t candidates = 0;  ///< planes with enough area seen on the way
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< of the refit inliers, camera frame [m]
};

/// Footprint area of one pixel seen at depth z_m on a plane at distance plane_distance_m [m^2].
double pixel_area_m2(double z_m, double plane_distance_m, const Intrinsics& intrinsics);

/// True when the point is finite and its depth within [min_depth_m, max_depth_m].
inline bool usable(const Eigen::Vector3f& p, const PlaneParams& params) {
  if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) return false;
  return p.z() >= params.min_depth_m && p.z() <= params.max_depth_m;
}

/// Finds the top plane: the nearest (along its normal) plane facing the camera whose inliers
/// cover at least min_plane_area_m2; refits it by least squares on full-resolution inliers.
/// `usable_points`: the number of usable points when the caller has counted them (0: counted here).
/// `up_camera`: the robot base's +z axis in camera coordinates (from camera_to_base); with it,
/// only level planes count (normal within max_base_tilt_deg of it), else planes whose normal lies
/// within max_tilt_deg of the view axis.
TopPlane find_top_plane(const OrganizedCloud& cloud, const Intrinsics& intrinsics,
                        const PlaneParams& params, std::size_t usable_points = 0,
                        const std::optional<Eigen::Vector3d>& up_camera = std::nullopt);

// ---- stage 2: plane frame --------------------------------------------------------------------

/// Layer frame: z along the normal (toward the camera), x the projection of the camera x axis,
/// origin the projection of `origin_camera` onto the plane. Returns T_camera_layer.
Eigen::Isometry3d layer_frame(const Plane& plane, const Eigen::Vector3d& origin_camera);

/// Default passthrough band from the noise sigma: 3 sigma + 4 mm, within [6 mm, kMaxBand] [m].
double default_passthrough_tolerance(double sigma_m);

/// The passthrough band per depth, tabulated for the per-pixel loops: a fixed band when
/// fixed_m > 0, else DepthNoise::band_at.
class BandTable {
 public:
  BandTable(const DepthNoise& noise, double fixed_m);
  explicit BandTable(double fixed_m) : BandTable(DepthNoise{}, fixed_m) {}
  [[nodiscard]] float at(float z_m) const {
    const float x = (z_m - z0_) * inv_step_;
    if (!(x > 0.0F)) return band_.front();
    const auto i = static_cast<std::size_t>(x);
    return i < band_.size() ? band_[i] : band_.back();
  }
  [[nodiscard]] double max_m() const { return max_m_; }
  [[nodiscard]] double min_m() const { return min_m_; }

 private:
  float z0_ = 0.0F, inv_step_ = 0.0F;
  std::vector<float> band_;
  double max_m_ = 0.0, min_m_ = 0.0;
};

// ---- stage 3: mask and border ----------------------------------------------------------------

struct LayerMask {
  cv::Mat mask;    ///< CV_8U, 255 = layer pixel after cleaning
  cv::Mat border;  ///< CV_8U, 255 = border pixel (a layer pixel with an 8-neighbour off the layer)
  std::size_t raw_layer_pixels = 0;
  std::size_t filled_dropouts = 0;
  bool touches_image_border = false;
};

/// Layer pixels (|signed distance| <= the band at their depth), invalid pixels nearly surrounded by layer
/// filled, one-pixel spurs (flying pixels) removed by an opening, border pixels marked.
LayerMask layer_mask(const OrganizedCloud& cloud, const Plane& plane, const BandTable& band,
                     const PlaneParams& validity);

/// Border pixels of a mask from the 8-neighbourhood (pixels outside the image count as off).
cv::Mat border_of(const cv::Mat& mask);

// ---- stage 3b: one level ---------------------------------------------------------------------

/// Pieces of one level differ along the calibrated up by the calibration's error over their
/// distance (1 degree over 1.5 m: 26 mm) and the sensor's noise; pieces further apart in height
/// than this are no one level [m].
constexpr double kMaxPieceSpread_m = 0.04;

/// The plane refitted on the highest piece of the layer mask.
struct PieceLevel {
  Plane plane;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< of the piece's points, camera frame [m]
  double step_m = 0.0;  ///< from the lowest piece's median height up to the highest's [m]
};

/// With the calibrated up (`up_camera`, camera frame): where the mask's pieces (8-connected, a
/// few hundred points or more) lie at median heights along up more than kMaxPieceSpread_m apart,
/// the plane was laid across two levels (seen at a slant far off, a deck and the floor beyond
/// meet a plane tilted a few degrees): the plane through the highest piece, when that piece is
/// level within max_base_tilt_deg. Otherwise nullopt. Pieces of one level lie on the highest
/// one's plane too, whatever the calibration's error, and stay in its band.
std::optional<PieceLevel> highest_piece_level(const cv::Mat& mask, const OrganizedCloud& cloud,
                                              const Plane& plane, const Eigen::Vector3d& up_camera,
                                              const PlaneParams& params);

// ---- stage 4: components and holes -----------------------------------------------------------

/// One ring's border pixels in chain order (the order findContours traced them, first visit).
struct RingPixels {
  std::vector<cv::Point> pixels;
  std::vector<int> chain;  ///< position along the traced contour of each pixel
  bool hole = false;
};

struct Component {
  RingPixels outer;
  std::vector<RingPixels> holes;
  double area_m2 = 0.0;
};

struct Components {
  std::vector<Component> kept;
  std::size_t dropped = 0;
  /// The largest dropped component that reaches the image's edge [m^2]: part of a carton the
  /// image cuts off (0: none).
  double largest_cut_m2 = 0.0;
};

/// Components (8-connected) with their holes from cv::findContours (RETR_CCOMP); components
/// smaller than min_area_m2 dropped (and erased from `mask`), holes enclosing <= min_hole_area_px
/// filled in `mask` (dropouts). `border` is recomputed from the cleaned mask; every border pixel
/// next to a traced ring joins that ring.
Components find_components(cv::Mat& mask, cv::Mat& border, const OrganizedCloud& cloud,
                           const Plane& plane, const Intrinsics& intrinsics, double min_area_m2,
                           int min_hole_area_px);

// ---- stage 5: crust and polygon ----------------------------------------------------------------

/// Pixel -> layer-plane coordinates through the pixel's viewing ray (exact, noise-free in z).
class PixelToLayer {
 public:
  PixelToLayer(const Intrinsics& intrinsics, const Plane& plane, const Eigen::Isometry3d& T_camera_layer);
  /// Layer-frame xy of the ray of pixel (u, v) (may lie outside the image) meeting the plane.
  [[nodiscard]] Eigen::Vector2d operator()(double u, double v) const;

 private:
  Intrinsics intrinsics_;
  Plane plane_;
  Eigen::Isometry3d T_layer_camera_;
  cv::Mat camera_matrix_, distortion_;
};

/// Crust: Delaunay of the points, edges longer than d_max pruned, convex-hull anchors joined by
/// shortest paths. `chain` gives each point's position along its traced ring (restricts each
/// path to its stretch of the ring). Returns the ring as point indices; fills `kept_edges`.
std::vector<int> crust_ring(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& chain,
                            double d_max_m, std::vector<std::pair<int, int>>* kept_edges);

/// One edge of a ring being simplified: the line through `point` along `dir`, fitted to `samples`
/// once `fitted`; `length` is the length of the polygon edge it stands for [m].
struct FittedLine {
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  Eigen::Vector2d dir = Eigen::Vector2d::UnitX();  ///< unit
  std::vector<Eigen::Vector2d> samples;
  double length = 0.0;
  bool fitted = false;
};

/// Total least squares line through the samples (a line with fewer than 3 is left as it is);
/// keeps the sign of `line.dir`.
void fit_line(FittedLine& line);

/// One rectangle through the samples, when they show one (its sides fitted with one common
/// direction, nearly every sample near its outline, its corners near the samples' hull);
/// counter-clockwise. False keeps the ring's own polygon.
bool fit_rectangle(const std::vector<Eigen::Vector2d>& samples, double pitch_m, Ring2d& rect);

/// Simplifies an ordered ring to a polygon: corner candidates by Douglas-Peucker, one line fitted
/// per edge to the edge samples (midpoints between layer and off-layer pixels), near-grid edges
/// snapped to the ring's dominant direction, near-parallel neighbours merged, corners from
/// intersecting consecutive lines. Orientation as given by the ring.
/// Right angles the raster blunted come back: a ring whose samples show one rectangle becomes that
/// rectangle, and two long fitted grid-aligned lines meeting at a near-right angle with one to
/// three edges between them meet in one corner, when the samples around it agree (a corner cut by
/// more than about 2.5 pitches along each side, a notch or a step between boxes is kept).
/// `sample_origins` (optional, one per sample): the border pixel each sample was taken from; a
/// sample then qualifies for the edges its pixel lies near (within 1.5 pitches), not only those
/// it lies near itself (samples beyond a foreshortened pixel step lie further from the ring).
Ring2d simplify_ring(const std::vector<Eigen::Vector2d>& ring, const std::vector<Eigen::Vector2d>& samples,
                     double pitch_m, const ContourParams& params,
                     const std::vector<Eigen::Vector2d>* sample_origins = nullptr);

}  // namespace palletd::layer
