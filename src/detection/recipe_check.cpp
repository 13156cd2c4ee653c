// check_recipe(): the boxes' measured side lengths against the recipe's formats.
#include "palletd/detection/recipe_check.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "palletd/detection/detection.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

namespace {

/// Median of the positive values; -1 with fewer than `min_count`.
double median_of(std::vector<double> v, int min_count) {
  if (v.empty() || static_cast<int>(v.size()) < std::max(1, min_count)) return -1.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Whether an upper bound of a side (-1: none) is not below the nominal length's lower tolerance.
bool not_under(double bound_m, double nominal_m, const RecipeCheckParams& p, double pitch_m) {
  if (bound_m <= 0.0) return true;
  return bound_m >= nominal_m - std::max(1e-3 * p.undersize_tolerance_mm, p.undersize_pitches * pitch_m);
}

/// Whether a measured side (-1: not measured) lies within the tolerance of its nominal length.
bool within(double measured_m, double nominal_m, const RecipeCheckParams& p, double pitch_m, double max_oversize) {
  if (measured_m <= 0.0) return true;
  const double under_m = std::max(1e-3 * p.undersize_tolerance_mm, p.undersize_pitches * pitch_m);
  const double over_m = std::max(1e-3 * p.oversize_tolerance_mm, p.oversize_pitches * pitch_m);
  return measured_m >= nominal_m - under_m && measured_m <= nominal_m * (1.0 + max_oversize) + over_m;
}

std::string describe(const FormatCheck& f, bool taped_across, bool taped_halves) {
  auto mm = [](double m) { return m > 0.0 ? std::to_string(static_cast<int>(std::lround(1e3 * m))) : std::string("?"); };
  const bool by_rows = f.measured_long_m <= 0.0 && f.measured_short_m <= 0.0;
  const double l = f.measured_long_m > 0.0 ? f.measured_long_m : f.run_long_m;
  const double s = f.measured_short_m > 0.0 ? f.measured_short_m : f.run_short_m;
  std::string out = "the boxes of format " + std::to_string(f.format) + " (" + mm(f.nominal_long_m) + " x " +
                    mm(f.nominal_short_m) + " mm) measure " + (by_rows ? "at most " : "") + mm(l) + " x " +
                    mm(s) + " mm";
  if (taped_across) {
    out +=
        ", and " + std::to_string(f.boxes_tape_across) +
        " of them carry tape across their middle, none along it (a carton is taped lengthwise: each is part "
        "of a carton laid the other way)";
  }
  if (taped_halves) {
    out += ", and " + std::to_string(f.boxes_tape_halves) +
           " of them carry tape across each half, none along the middle (each is two cartons laid the other "
           "way)";
  }
  return out;
}

}  // namespace

bool taped_across_unmeasured(const DetectedBox& box) {
  return box.tape_across && (box.measured_short_m <= 0.0 || box.measured_long_m <= 0.0);
}

RecipeCheck check_recipe(const std::vector<DetectedBox>& boxes, const std::vector<BoxFormat>& formats,
                         const RecipeCheckParams& params, double pixel_pitch_m, double max_oversize) {
  RecipeCheck out;
  if (!params.enabled) return out;
  std::vector<double> residuals;
  for (std::size_t f = 0; f < formats.size(); ++f) {
    std::vector<double> along_long, along_short, run_long, run_short;
    FormatCheck c;
    for (const DetectedBox& b : boxes) {
      if (b.format != static_cast<int>(f) || b.partly_unseen) continue;
      if (b.measured_long_m > 0.0) along_long.push_back(b.measured_long_m);
      if (b.measured_short_m > 0.0) along_short.push_back(b.measured_short_m);
      if (b.run_long_m > 0.0) run_long.push_back(b.run_long_m);
      if (b.run_short_m > 0.0) run_short.push_back(b.run_short_m);
      if (taped_across_unmeasured(b)) ++c.boxes_tape_across;
      if (b.tape_halves) ++c.boxes_tape_halves;
    }
    c.format = static_cast<int>(f);
    c.nominal_long_m = formats[f].long_m;
    c.nominal_short_m = formats[f].short_m;
    c.boxes_long = static_cast<int>(along_long.size());
    c.boxes_short = static_cast<int>(along_short.size());
    c.measured_long_m = median_of(along_long, params.min_boxes_measured);
    c.measured_short_m = median_of(along_short, params.min_boxes_measured);
    // Distance of a measured side from the band real cartons are built in: nominal .. + oversize.
    auto off_band = [&](double measured_m, double nominal_m) {
      return std::max({0.0, nominal_m - measured_m, measured_m - nominal_m * (1.0 + max_oversize)});
    };
    if (c.measured_long_m > 0.0) residuals.push_back(off_band(c.measured_long_m, c.nominal_long_m));
    if (c.measured_short_m > 0.0) residuals.push_back(off_band(c.measured_short_m, c.nominal_short_m));
    if (c.measured_long_m < 0.0) c.run_long_m = median_of(run_long, params.min_boxes_measured);
    if (c.measured_short_m < 0.0) c.run_short_m = median_of(run_short, params.min_boxes_measured);
    if (c.measured_long_m > 0.0 || c.measured_short_m > 0.0 || c.run_long_m > 0.0 || c.run_short_m > 0.0)
      out.checked = true;
    c.agrees = within(c.measured_long_m, c.nominal_long_m, params, pixel_pitch_m, max_oversize) &&
               within(c.measured_short_m, c.nominal_short_m, params, pixel_pitch_m, max_oversize) &&
               not_under(c.run_long_m, c.nominal_long_m, params, pixel_pitch_m) &&
               not_under(c.run_short_m, c.nominal_short_m, params, pixel_pitch_m);
    const bool sizes_agree = c.agrees;
    const bool taped_across = params.taped_across(c.boxes_tape_across);
    const bool taped_halves = params.taped_across(c.boxes_tape_halves);
    if (taped_across || taped_halves) {
      out.checked = true;
      c.agrees = false;
      // Half of a carton the recipe holds, or two: the layout chose the wrong format.
      if ((taped_across && doubled_format(formats, formats[f]) >= 0) ||
          (taped_halves && halved_format(formats, formats[f]) >= 0))
        out.some_agree = true;
    }
    const bool measured = c.measured_long_m > 0.0 || c.measured_short_m > 0.0;
    if (c.agrees && measured) out.some_agree = true;
    // Boxes that measure as another format of the recipe: the layout chose the wrong format.
    for (std::size_t g = 0; g < formats.size() && !c.agrees; ++g) {
      if (g != f && within(c.measured_long_m, formats[g].long_m, params, pixel_pitch_m, max_oversize) &&
          within(c.measured_short_m, formats[g].short_m, params, pixel_pitch_m, max_oversize))
        out.some_agree = true;
    }
    if (!c.agrees) {
      out.tape_only = (out.agrees || out.tape_only) && sizes_agree;
      out.agrees = false;
      out.reason += (out.reason.empty() ? "" : "; ") + describe(c, taped_across, taped_halves);
    }
    out.formats.push_back(c);
  }
  out.size_residual_m = median_of(residuals, 1);
  if (!out.agrees) {
    out.reason += out.some_agree ? ": boxes of a format the layer may not hold"
                  : out.tape_only
                      ? ": the cartons lie otherwise than these boxes (another arrangement or other cartons)"
                      : ": the layer is not built of the recipe's cartons";
  }
  return out;
}

}  // namespace palletd
