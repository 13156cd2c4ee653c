// Refinement internals (private to the layout stage): robust edge-line fits and the joint
// least-squares fit of all boxes of a layout component in its layout frame.
#pragma once

#include <limits>
#include <vector>

#include <Eigen/Core>

namespace palletd::layout_detail {

/// A straight box side measured from samples (t along the side, p across it):
/// p = offset_m + slope * (t - t_ref).
struct EdgeLine {
  bool ok = false;
  double offset_m = 0.0;        ///< across position at t_ref [m]
  double slope = 0.0;           ///< dp/dt [rad, small angle]
  double sigma_offset_m = 0.0;  ///< standard error of offset_m [m]
  double sigma_slope = 0.0;     ///< standard error of slope
  double scale_m = 0.0;         ///< robust residual scale (MAD, floored) [m]
  int inliers = 0;              ///< samples with non-zero weight
};

/// Robust line fit (Tukey biweight, scale from the MAD of the residuals, floored at floor_m,
/// the quantisation of the samples). Fails (ok = false) with fewer than min_samples samples
/// or fewer than min_samples inliers. A fitted slope steeper than max_slope is taken for stray
/// samples: the side is then fitted flat (slope 0, not measured: sigma_slope infinite; its
/// offset's standard error allows for a slope of max_slope).
EdgeLine fit_edge_line(const std::vector<Eigen::Vector2d>& samples, double t_ref, double floor_m,
                       int min_samples = 5, double max_slope = std::numeric_limits<double>::infinity());

/// One box of the joint fit in the layout frame: axis-aligned, sides at center +- half.
struct JointBox {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();        ///< [m]
  Eigen::Vector2d half = Eigen::Vector2d::Zero();          ///< half extents along frame x, y [m]
  Eigen::Vector2d half_nominal = Eigen::Vector2d::Zero();  ///< nominal format, same axes [m]
  /// Standard deviation of the fitted centre along frame x, y (solve_joint's output) [m]
  Eigen::Vector2d sigma_center = Eigen::Vector2d::Zero();
  /// Standard deviation of the fitted half size along frame x, y (solve_joint's output) [m]
  Eigen::Vector2d sigma_half = Eigen::Vector2d::Zero();
  /// Where the size prior is centred along frame x, y; 0 = half_nominal (solve_joint sets it to
  /// the batch's size for its second pass) [m]
  Eigen::Vector2d half_prior = Eigen::Vector2d::Zero();
};

/// A measured box side: the side of box `box` normal to `axis` (0: frame x) on side `sign`
/// (-1 / +1) lies at pos_m +- sigma_m.
struct SideObservation {
  int box = 0;
  int axis = 0;
  int sign = 1;
  double pos_m = 0.0;
  double sigma_m = 0.001;
};

/// Two neighbours pressed together where no seam is seen: the +side of box a touches the
/// -side of box b along `axis` (gap 0 +- sigma_m).
struct Contact {
  int a = 0;
  int b = 0;
  int axis = 0;
  double sigma_m = 0.001;
};

/// Where a box side lies relative to what the pixels show, from the pixel footprint and the view.
/// `view_slope`: tan of the angle between the viewing ray at the side and the layer normal,
/// measured outward (> 0: the camera lies beyond the side, its wall faces the camera; < 0: the
/// side faces away). `pitch_m`: pixel footprint on the layer across the side. `drop_m`: the
/// smallest depth step beyond a side that hides what lies behind it (a box height).
/// Outline side (measured as the outermost layer point plus half a footprint): a side facing the
/// camera hides the floor behind its wall, so pixels straddling the edge keep top depth and stay
/// on the layer (edge = outermost point, -pitch/2); a side facing away (or seen straight on)
/// mixes the straddling pixel with the deep floor, it leaves the layer, and the edge lies a
/// whole footprint beyond the last layer point's centre (+pitch/2). The two blend linearly over
/// 0 < view_slope < pitch / drop (until the wall hides one footprint of the floor).
/// Returns the correction to add to the outward side position [m].
double outline_footprint_correction(double view_slope, double pitch_m, double drop_m);

/// Seam side (measured as the box's edge of the seam band, where the band reaches 0.5): a pixel
/// turns seam-like as soon as its footprint reaches into the gap, so the band starts half a
/// footprint inside the box, unless the side faces the camera (its wall is seen in the gap with
/// top-like depth): +pitch/2 blended to 0 as for outline sides.
double seam_footprint_correction(double view_slope, double pitch_m, double drop_m);

struct JointParams {
  double size_sigma_m = 0.005;      ///< prior spread of a real side length around nominal [m]
  double size_tolerance_m = 0.010;  ///< a side length stays within nominal +- this [m] ...
  /// ... or grows up to this share over nominal: real cartons are built 1-5 % over their format.
  double max_oversize = 0.06;
  /// Spread of side lengths between cartons of one format on a layer (one batch) [m]; 0 = untied.
  double batch_sigma_m = 0.004;
  double anchor_sigma_m = 0.05;     ///< weak prior keeping an unmeasured box where it was [m]
};

/// Fits every box centre and half size along both frame axes to the side observations,
/// contacts and priors (linear least squares, Huber-reweighted side observations; sizes
/// clamped to the tolerance and the fit repeated with clamped sizes held). `neighbours` are
/// facing sides of adjacent boxes (same layout as Contact): boxes are solid, so where the fit
/// makes such a pair overlap, the pair is made to touch instead and the fit repeated.
/// The axes are fitted one after the other, each with its own batch ties; a carton's side of one
/// nominal length stands along x in some boxes and along y in others (an interlock, a pinwheel),
/// so a second pass centres every size prior on the batch's size measured along both axes.
void solve_joint(std::vector<JointBox>& boxes, const std::vector<SideObservation>& sides,
                 const std::vector<Contact>& contacts, const JointParams& params,
                 const std::vector<Contact>& neighbours = {});

}  // namespace palletd::layout_detail
