// look_alike_formats(): formats of one recipe a layer cannot tell apart by their size.
#include "palletd/detection/look_alike_formats.hpp"

#include <algorithm>
#include <cmath>

namespace palletd {

std::vector<LookAlikeFormats> look_alike_formats(const std::vector<BoxFormat>& formats, double max_oversize,
                                                 double max_gap_m) {
  std::vector<LookAlikeFormats> out;
  const auto alike = [&](double x_m, double y_m) {
    return std::abs(x_m - y_m) <= max_oversize * std::max(x_m, y_m) + max_gap_m;
  };
  for (std::size_t a = 0; a < formats.size(); ++a) {
    for (std::size_t b = a + 1; b < formats.size(); ++b) {
      const BoxFormat& fa = formats[a];
      const BoxFormat& fb = formats[b];
      if (alike(fa.long_m, fb.long_m) && alike(fa.short_m, fb.short_m)) {
        out.push_back({a, b, std::abs(fa.long_m - fb.long_m), std::abs(fa.short_m - fb.short_m)});
      }
    }
  }
  return out;
}

bool same_carton(const BoxFormat& a, const BoxFormat& b) {
  constexpr double kSame_m = 0.0005;
  const bool heights_alike =
      (a.height_m <= 0.0 && b.height_m <= 0.0) || std::abs(a.height_m - b.height_m) < kSame_m;
  return std::abs(a.long_m - b.long_m) < kSame_m && std::abs(a.short_m - b.short_m) < kSame_m &&
         heights_alike;
}

}  // namespace palletd
