// palletd results: a carton size taught from a frame (palletctl teach): the sizes measured on a
// layer of cartons nobody entered, summed up as a format and a recipe entry for the config.
#pragma once

#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"

namespace palletd {

/// One carton size the frame shows.
struct TaughtFormat {
  int long_mm = 0, short_mm = 0;  ///< median of the boxes' sizes, rounded to whole millimetres
  double spread_mm = 0.0;         ///< the larger side's median absolute deviation over the boxes [mm]
  int boxes = 0;
};

struct Teaching {
  bool taught = false;  ///< the frame settles the size: a layout, not flagged
  std::string reason;   ///< why not, when taught is false; the flags otherwise
  std::vector<TaughtFormat> formats;
};

/// What a detection with measured sizes (detect_unknown_cartons()) teaches: the boxes' sizes
/// grouped within 15 mm. Not taught when the frame has no layout or the size is in doubt.
Teaching teach_from(const Detection& detection);

/// The config lines to paste: a `formats` entry per size and a `recipes` entry that lists them.
std::string recipe_yaml(const Teaching& teaching, int recipe_number, const std::string& recipe_name);

}  // namespace palletd
