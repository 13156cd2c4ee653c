// Known layouts as the layout stage's frame boxes, for the tests that reach its private headers
// (palletd_layout_tests).
#pragma once

#include <vector>

#include "layout_fixtures.hpp"
#include "layout_internal.hpp"

namespace palletd::layout_test {

/// A known layout's boxes as frame boxes (the layout frame is the layout's own).
inline std::vector<layout_detail::FrameBox> frame_boxes(const KnownLayout& k) {
  std::vector<layout_detail::FrameBox> out;
  for (const TruthBox& b : k.boxes) {
    const BoxFormat& f = k.formats[static_cast<std::size_t>(b.format)];
    const double w = b.long_along_x ? f.long_m : f.short_m, h = b.long_along_x ? f.short_m : f.long_m;
    out.push_back({layout_detail::Rect{b.x0, b.y0, b.x0 + w, b.y0 + h}, b.format, b.long_along_x});
  }
  return out;
}

}  // namespace palletd::layout_test
