// palletd detection: how well the camera sees the cell, measured on one frame. A dirty window, a
// failing illuminator or stray light show here before detection fails: more pixels without depth,
// more mixed ("flying") pixels at the layer's edges, saturated pixels, a noisier layer plane than
// the camera's noise model. Pure: the frame and the first half of the pipeline in, figures out;
// the rolling window and the limits are the service's.
#pragma once

#include <cstddef>
#include <optional>

#include "palletd/core/frame.hpp"
#include "palletd/detection/layer.hpp"

namespace palletd {

struct RegionOfInterest;

/// The camera's depth noise along the optical axis at range r: sigma = sigma_mm_at_1m (r / 1 m)^exponent.
/// Time-of-flight cameras grow about linearly with range (exponent 1: the returned light falls
/// with r^2, the noise with its square root); structured light and stereo grow with r^2.
struct DepthNoiseModel {
  double sigma_mm_at_1m = 0.0;  ///< 0: no model, the plane noise is measured but not compared
  double exponent = 1.0;

  [[nodiscard]] bool enabled() const { return sigma_mm_at_1m > 0.0; }
  [[nodiscard]] double sigma_mm(double range_m) const;
};

/// One frame's figures. Shares are of the pixels whose viewing ray crosses the region of interest
/// (the whole image without one), so a cabinet beside the load does not count.
struct FrameHealth {
  bool measured = false;          ///< false only for a frame detect() could not read
  std::size_t roi_pixels = 0;     ///< pixels whose ray crosses the region of interest
  double invalid_fraction = 0.0;  ///< of roi_pixels: no depth
  /// Of roi_pixels: intensity at full scale (null: the frame has no intensity image).
  std::optional<double> saturated_fraction;
  /// Of the pixels with depth within 2 px outside the layer: mixed pixels, whose depth lies
  /// between a nearer and a farther neighbour across a jump that runs along the viewing ray
  /// (null: no layer was found).
  std::optional<double> flying_fraction;
  std::optional<double> plane_noise_mm;  ///< robust sigma of the layer plane's residuals (null: no plane)
  std::optional<double>
      model_noise_mm;                 ///< the noise model at the layer's range (null: no model or no plane)
  std::optional<double> noise_ratio;  ///< plane_noise_mm / model_noise_mm
};

/// Measures one frame. `roi`: the region of interest (null: the whole view; a base-frame region
/// needs the frame's T_base_camera, else the whole view counts). `layer` is extract_layer()'s
/// result (any status: without a plane only the pixel shares are measured).
FrameHealth measure_frame_health(const Frame& frame, const RegionOfInterest* roi, const LayerResult& layer,
                                 const DepthNoiseModel& noise_model);

}  // namespace palletd
