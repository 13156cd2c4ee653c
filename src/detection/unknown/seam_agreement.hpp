// How well a layout's box sides agree with the seams a frame shows: the private measure by which
// detect_unknown_cartons() tells one carton size from another.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/layer.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

/// The layer's seams, once per frame, in the layer frame of `layer`.
class SeamAgreement {
 public:
  /// margin_m: seams and box sides this close to the outline are not looked at (the outline
  /// itself shows as a seam there).
  SeamAgreement(const LayerResult& layer, const SeamEvidence& seams, double margin_m);

  struct Score {
    double explained = 0.0;  ///< share of the seams seen that run along a side of some box
    double shown = 0.0;      ///< share of the boxes' inner sides along which a seam is seen
    /// A seam seen where no box side runs is strong evidence against a size (seams do not appear
    /// from nothing); a side without a seam is weak (narrow gaps do not show): squared and plain.
    [[nodiscard]] double product() const { return explained * explained * shown; }
  };

  /// `boxes` laid out on this layer (their `in_layer` in its frame). Boxes taken in pairs of one
  /// size where two cartons stand leave a seam across the pair's top unexplained; cartons halved predict
  /// seams the frame does not show. Both lower the score; a camera that shows few seams lowers every size's
  /// alike (`shown` small).
  [[nodiscard]] Score score(const std::vector<DetectedBox>& boxes) const;

  [[nodiscard]] std::size_t seam_cells() const { return seam_cells_.size(); }

 private:
  [[nodiscard]] bool inner(const Eigen::Vector2d& p) const;  ///< inside the layer, off the outline
  [[nodiscard]] cv::Point cell_of(const Eigen::Vector2d& p) const;

  Eigen::Vector2d origin_m_ = Eigen::Vector2d::Zero();
  double cell_m_ = 0.003;
  double margin_m_ = 0.012;
  double band_m_ = 0.009;
  std::vector<std::vector<cv::Point2f>> outlines_;  ///< outer rings of the layer's components
  std::vector<cv::Point> seam_cells_;               ///< seam cells off the outline
  cv::Mat seams_near_;                              ///< seam within band_m_ of the cell (CV_8U)
};

}  // namespace palletd
