// SeamAgreement: the seams a frame shows against the sides of a layout's boxes.
#include "seam_agreement.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace palletd {

namespace {

std::vector<cv::Point2f> to_cv(const Ring2d& ring) {
  std::vector<cv::Point2f> out;
  out.reserve(ring.size());
  for (const auto& p : ring) out.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  return out;
}

/// Spacing of the samples along a box side [m].
constexpr double kSideStep_m = 0.01;
/// Half the width of the tape along a carton's flap line (48 mm tape) [m].
constexpr double kTapeHalfWidth_m = 0.024;

}  // namespace

SeamAgreement::SeamAgreement(const LayerResult& layer, const SeamEvidence& seams, double margin_m)
    : origin_m_(seams.origin_m),
      cell_m_(seams.cell_m),
      margin_m_(margin_m),
      band_m_(std::max(0.009, 3.0 * seams.cell_m)) {
  for (const PolygonWithHoles& polygon : layer.polygons) {
    outlines_.push_back(to_cv(polygon.outer));
    for (const Ring2d& hole : polygon.holes) outlines_.push_back(to_cv(hole));
  }
  if (seams.empty()) return;
  cv::Mat seam(seams.height, seams.width, CV_8U, cv::Scalar(0));
  for (int iy = 0; iy < seams.height; ++iy) {
    for (int ix = 0; ix < seams.width; ++ix) {
      if (seams.at(ix, iy) <= 0.5F) continue;
      seam.at<std::uint8_t>(iy, ix) = 255;
      if (inner(origin_m_ + cell_m_ * Eigen::Vector2d(ix + 0.5, iy + 0.5))) seam_cells_.emplace_back(ix, iy);
    }
  }
  const int r = static_cast<int>(std::ceil(band_m_ / cell_m_));
  cv::dilate(seam, seams_near_, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
}

bool SeamAgreement::inner(const Eigen::Vector2d& p) const {
  const cv::Point2f pt(static_cast<float>(p.x()), static_cast<float>(p.y()));
  bool inside = false;
  for (const auto& ring : outlines_) {
    const double d = cv::pointPolygonTest(ring, pt, true);
    if (std::abs(d) < margin_m_) return false;  // on an outline or a hole's edge
    if (d > 0.0) inside = !inside;              // inside an outer ring and not in its hole
  }
  return inside;
}

cv::Point SeamAgreement::cell_of(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d q = (p - origin_m_) / cell_m_;
  return {static_cast<int>(std::floor(q.x())), static_cast<int>(std::floor(q.y()))};
}

SeamAgreement::Score SeamAgreement::score(const std::vector<DetectedBox>& boxes) const {
  Score s;
  if (seams_near_.empty() || boxes.empty()) return s;
  cv::Mat sides(seams_near_.size(), CV_8U, cv::Scalar(0));
  const int thickness = std::max(1, static_cast<int>(std::lround(2.0 * band_m_ / cell_m_)));
  std::size_t samples = 0, samples_seen = 0;
  for (const DetectedBox& box : boxes) {
    const std::vector<Eigen::Vector2d> corners = box.in_layer.corners();
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d a = corners[k], b = corners[(k + 1) % 4];
      cv::line(sides, cell_of(a), cell_of(b), cv::Scalar(255), thickness);
      const int n = std::max(1, static_cast<int>((b - a).norm() / kSideStep_m));
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d p = a + (b - a) * ((i + 0.5) / n);
        if (!inner(p)) continue;  // an outer side: the outline, not a seam, bounds it
        const cv::Point c = cell_of(p);
        if (c.x < 0 || c.y < 0 || c.x >= seams_near_.cols || c.y >= seams_near_.rows) continue;
        ++samples;
        if (seams_near_.at<std::uint8_t>(c) != 0) ++samples_seen;
      }
    }
  }
  // A carton's flaps meet along the middle of its top, lengthwise, often under a strip of tape:
  // a line there is the carton's own, not a seam between two.
  const int flap_thickness =
      std::max(1, static_cast<int>(std::lround(2.0 * (band_m_ + kTapeHalfWidth_m) / cell_m_)));
  for (const DetectedBox& box : boxes) {
    const std::vector<Eigen::Vector2d> c = box.in_layer.corners();
    cv::line(sides, cell_of(0.5 * (c[0] + c[3])), cell_of(0.5 * (c[1] + c[2])), cv::Scalar(255),
             flap_thickness);
  }
  std::size_t explained = 0;
  for (const cv::Point& c : seam_cells_) explained += sides.at<std::uint8_t>(c) != 0 ? 1 : 0;
  // No seam seen: nothing to explain. No inner side: a single carton, nothing to show.
  s.explained =
      seam_cells_.empty() ? 1.0 : static_cast<double>(explained) / static_cast<double>(seam_cells_.size());
  s.shown = samples == 0 ? 1.0 : static_cast<double>(samples_seen) / static_cast<double>(samples);
  return s;
}

}  // namespace palletd
