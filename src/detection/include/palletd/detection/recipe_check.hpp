// palletd detection: does the layer agree with the recipe? The boxes' sides measured on the frame
// (the outline and the seams on both opposite sides of a box) against the recipe's formats, and
// which of several recipes fits a frame best.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "palletd/core/geometry.hpp"

namespace palletd {

struct DetectedBox;

/// When a layer counts as built of other cartons than the recipe's (config detection.recipe_check).
struct RecipeCheckParams {
  bool enabled = true;
  /// A format's measured side may run below nominal by max(this, undersize_pitches x the pixel
  /// pitch): cartons are not built smaller than their format, but a rounded top edge and the
  /// pixel footprint shave a little off the measured top [mm].
  double undersize_tolerance_mm = 6.0;
  double undersize_pitches = 1.0;
  /// ... and above nominal by the oversize share real cartons run to (LayoutParams::refine
  /// max_oversize) plus max(this, oversize_pitches x the pixel pitch) [mm]: a stereo camera
  /// fattens a depth edge toward the lower side by up to two pixels, so a top measures up to four
  /// pixels larger on both axes (a time-of-flight camera's mixed pixels do not).
  double oversize_tolerance_mm = 5.0;
  double oversize_pitches = 4.0;
  /// Boxes of a format with a side measured along an axis before that side is judged: one box's
  /// pair of sides can be misread (a label edge, a dent), the median of several is the carton.
  int min_boxes_measured = 2;
  /// Boxes of a format with a band of tape across their middle and none along it
  /// (DetectedBox::tape_across) that make the format disagree: such a box is part of a carton
  /// laid the other way. The same count of boxes with a band across each half
  /// (DetectedBox::tape_halves: two cartons laid the other way) does too. 0 = tape not used.
  int min_boxes_tape_across = 2;

  /// Whether `boxes` of a format taped across (taped_across_unmeasured()) or in halves
  /// (DetectedBox::tape_halves) say the cartons lie the other way.
  [[nodiscard]] bool taped_across(int boxes) const {
    return min_boxes_tape_across > 0 && boxes >= min_boxes_tape_across;
  }
};

/// One format of the recipe against what the frame shows of it.
struct FormatCheck {
  int format = 0;
  double nominal_long_m = 0.0, nominal_short_m = 0.0;
  /// Median side lengths measured over the format's boxes [m]; -1 = fewer than
  /// min_boxes_measured boxes showed both sides along that axis.
  double measured_long_m = -1.0, measured_short_m = -1.0;
  int boxes_long = 0, boxes_short = 0;  ///< boxes measured along each axis
  /// Boxes with tape across their middle (tape_across), leaving out those measured on both axes.
  int boxes_tape_across = 0;
  /// Boxes with tape across each half (tape_halves), whatever was seen of their sides: the sides
  /// seen around two cartons under one box are the pair's outer sides.
  int boxes_tape_halves = 0;
  /// Where fewer boxes showed both sides: the median of the boxes' shares of rows pressed
  /// together (DetectedBox::run_long_m), an upper bound checked against the lower tolerance only
  /// [m]; -1 = not used.
  double run_long_m = -1.0, run_short_m = -1.0;
  /// Both medians, where measured, within the tolerance, and fewer than min_boxes_tape_across
  /// boxes with tape across.
  bool agrees = true;
};

/// The verdict on the whole layer (Detection::recipe_check).
struct RecipeCheck {
  bool checked = false;  ///< at least one format had a side measured on enough boxes
  bool agrees = true;    ///< every measured format within the tolerance
  /// Some format measured and within the tolerance, or a disagreeing format's boxes measure as
  /// another format of the recipe (or, taped across, are half a carton of another recipe format):
  /// the layout put boxes of a format the layer does not hold (flagged), rather than the layer
  /// being of other cartons.
  bool some_agree = false;
  /// Every format that disagrees does so by its boxes' tape alone (their measured sides agree):
  /// the tape says the cartons lie otherwise, which on a layout already flagged may mean another
  /// arrangement rather than other cartons (detect() then flags instead).
  bool tape_only = false;
  std::vector<FormatCheck> formats;
  std::string reason;    ///< a sentence when !agrees: which format, measured against nominal
  /// Median over the formats' measured sides of their distance from the band cartons are built
  /// in (nominal .. nominal x (1 + max_oversize)) [m]; -1 = nothing measured. Ranks recipes that
  /// agree alike (best_fitting_recipe()).
  double size_residual_m = -1.0;
  /// Recipe number of the configured recipe that fits the frame best (best_fitting_recipe());
  /// null when none was sought or none fits.
  std::optional<int> best_recipe;
};

/// Whether `box` counts as part of a carton laid the other way: tape across its middle
/// (DetectedBox::tape_across) and not all four of its sides seen (a box measured on both axes is
/// a carton; a band across it is then a label or a print).
bool taped_across_unmeasured(const DetectedBox& box);

/// Measured sides of the boxes against their formats. `pixel_pitch_m`: the layer's pixel pitch;
/// `max_oversize`: the share cartons may run over their format (RefineParams::max_oversize).
RecipeCheck check_recipe(const std::vector<DetectedBox>& boxes, const std::vector<BoxFormat>& formats,
                         const RecipeCheckParams& params, double pixel_pitch_m, double max_oversize);

}  // namespace palletd
