// Helpers shared by the level checks (level_checks.cpp, empty_level.cpp): lengths in words, a
// ring in millimetres and its smallest enclosing rectangle, the recipe's smallest top and sides.
#pragma once

#include <algorithm>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "palletd/detection/detection.hpp"

namespace palletd::level_detail {

/// "123 mm" for a length in metres.
inline std::string mm(double m) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(0);
  s << m * 1000.0 << " mm";
  return s.str();
}

/// The ring's points in millimetres, for OpenCV's geometry.
inline std::vector<cv::Point2f> points_mm(const Ring2d& ring) {
  std::vector<cv::Point2f> pts;
  pts.reserve(ring.size());
  for (const Eigen::Vector2d& v : ring)
    pts.emplace_back(static_cast<float>(v.x() * 1000.0), static_cast<float>(v.y() * 1000.0));
  return pts;
}

/// The ring's minimum-area enclosing rectangle [mm].
inline cv::RotatedRect min_area_rect(const Ring2d& ring) { return cv::minAreaRect(points_mm(ring)); }

/// The top area of the recipe's smallest format [m2].
inline double min_area_m2(const std::vector<BoxFormat>& formats) {
  double a = std::numeric_limits<double>::max();
  for (const BoxFormat& f : formats) a = std::min(a, f.long_m * f.short_m);
  return a;
}

/// The shortest short side of the recipe's formats [m].
inline double min_short_m(const std::vector<BoxFormat>& formats) {
  double s = 1e9;
  for (const BoxFormat& f : formats) s = std::min(s, f.short_m);
  return s;
}

}  // namespace palletd::level_detail
