// palletd sim: what the block matching of an active-stereo camera does to depth edges.
#include <algorithm>
#include <limits>

#include "sim_internal.hpp"

namespace palletd::sim::detail {
namespace {

constexpr double kStereoStep_m = 0.01;  ///< a neighbour nearer by more than this is foreground

}  // namespace

std::vector<std::size_t> stereo_sources(const std::vector<double>& z, int w, int h, int max_px, Rng& rng) {
  const double far = std::numeric_limits<double>::infinity();
  auto depth = [&](std::size_t i) { return z[i] > 0.0 ? z[i] : far; };  // no return = farthest
  std::vector<std::size_t> source(z.size());
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const std::size_t i = static_cast<std::size_t>(v * w + u);
      source[i] = i;
      // The matching window's reach varies along the edge, which makes the edge ragged.
      const int r = rng.integer(1, std::max(1, max_px));
      const double own = depth(i);
      int best_d2 = std::numeric_limits<int>::max();
      double best_z = far;
      for (int dv = -r; dv <= r; ++dv)
        for (int du = -r; du <= r; ++du) {
          const int uu = u + du, vv = v + dv;
          if (uu < 0 || vv < 0 || uu >= w || vv >= h) continue;
          const std::size_t j = static_cast<std::size_t>(vv * w + uu);
          const double zj = depth(j);
          if (z[j] <= 0.0 || zj >= own - kStereoStep_m) continue;
          const int d2 = du * du + dv * dv;
          if (d2 < best_d2 || (d2 == best_d2 && zj < best_z)) {
            best_d2 = d2;
            best_z = zj;
            source[i] = j;
          }
        }
    }
  return source;
}

}  // namespace palletd::sim::detail
