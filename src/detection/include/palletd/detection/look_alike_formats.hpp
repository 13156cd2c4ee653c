// Formats of one recipe whose cartons a layer cannot tell apart by their size (a commissioning
// check: palletd --check-config and the daemon's start warn about them).
#pragma once

#include <cstddef>
#include <vector>

#include "palletd/core/geometry.hpp"

namespace palletd {

/// Two formats whose cartons, as they stand on a layer, can take the same room.
struct LookAlikeFormats {
  std::size_t a = 0, b = 0;   ///< indices into the formats given, a < b
  double long_diff_m = 0.0;   ///< |long side of a - long side of b| [m]
  double short_diff_m = 0.0;  ///< |short side of a - short side of b| [m]
};

/// The pairs of `formats` whose long sides and whose short sides each differ by at most
/// `max_oversize` x the longer of the two plus `max_gap_m`: real cartons are built up to
/// max_oversize over their format (RefineParams::max_oversize) and stand with gaps of up to
/// max_gap_m between them, so a carton of either format with its share of the gaps can fill the
/// same rectangle of the outline. Only seams, tape and sides measured on the frame tell such
/// formats apart; where none shows, their layers are flagged.
std::vector<LookAlikeFormats> look_alike_formats(const std::vector<BoxFormat>& formats, double max_oversize,
                                                 double max_gap_m);

/// Whether two formats are one carton size: sides and heights (both unknown, or given) within
/// half a millimetre. A camera sees the same top either way; the layout search lays out the
/// first of such formats and its boxes carry that one's index.
bool same_carton(const BoxFormat& a, const BoxFormat& b);

}  // namespace palletd
