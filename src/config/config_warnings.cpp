// config_warnings(): what a valid configuration may still get wrong.
#include "palletd/config/config_warnings.hpp"

#include <cmath>

#include "palletd/detection/layout.hpp"
#include "palletd/detection/look_alike_formats.hpp"

namespace palletd {

std::vector<std::string> config_warnings(const Config& config) {
  const double max_gap_m = kMaxCartonGap_m;
  const double max_oversize = config.detection.layout.refine.max_oversize;
  const auto mm = [](double m) { return std::to_string(static_cast<int>(std::lround(1e3 * m))); };
  const std::string oversize_pct = std::to_string(static_cast<int>(std::lround(100.0 * max_oversize)));
  std::vector<std::string> out;
  for (const Recipe& r : config.recipes) {
    std::vector<BoxFormat> formats;
    for (int index : r.formats) formats.push_back(config.formats[static_cast<std::size_t>(index)]);
    for (const LookAlikeFormats& p : look_alike_formats(formats, max_oversize, max_gap_m)) {
      const BoxFormat& a = formats[p.a];
      const BoxFormat& b = formats[p.b];
      if (same_carton(a, b)) {
        out.push_back("recipe " + std::to_string(r.number) + " (" + r.name + "): formats " + a.name +
                      " and " + b.name + " are one carton size (" + mm(a.long_m) + "x" + mm(a.short_m) +
                      "): a camera sees the same top, so their boxes are reported as " + a.name +
                      ", the first of them");
        continue;
      }
      out.push_back("recipe " + std::to_string(r.number) + " (" + r.name + "): formats " + mm(a.long_m) +
                    "x" + mm(a.short_m) + " and " + mm(b.long_m) + "x" + mm(b.short_m) + " differ by " +
                    mm(p.long_diff_m) + " and " + mm(p.short_diff_m) +
                    " mm, no more than cartons run over their format (" + oversize_pct + " %) plus a gap (" +
                    mm(max_gap_m) +
                    " mm): only seams, tape or measured sides tell their cartons apart, and where none shows "
                    "their layers are flagged");
    }
  }
  return out;
}

}  // namespace palletd
