// palletd drivers: the frame recorder, a bounded ring of recorded frames on disk.
//
// Each recording is a frame in the frame format (shared/spec/frames.md) plus, when given, the
// detection result (STEM.detection.json) and the overlay image (STEM.overlay.png) beside it.
// Stems are "<UTC time>-<sequence>" so name order is time order and the replay driver plays a
// recording folder back as it was recorded.
//
// Power-cut safety: all files of a recording are written (and fsync'ed) in DIR/.partial/ first,
// then renamed into DIR with STEM.depth.png last. A frame is listed only once its depth PNG
// exists, so a cut at any moment leaves either a whole frame or files the next start removes.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"

namespace palletd {

struct RecorderOptions {
  std::string directory;                   ///< created when missing
  std::uint64_t max_bytes = 2ull << 30;    ///< ring size on disk [bytes]; oldest frames go first
};

class FrameRecorder {
 public:
  /// Does no I/O; the folder is scanned by the first record() (or by scan()).
  explicit FrameRecorder(RecorderOptions options);

  /// Creates the folder, removes leftovers of an interrupted write, and takes stock of the
  /// recordings already there (they count toward the ring size).
  Status scan();

  /// Records one frame, with the detection JSON text and encoded overlay PNG when not empty.
  /// Returns the stem written (DIR/STEM). Deletes the oldest recordings beyond max_bytes
  /// (never the one just written).
  Expected<std::string> record(const Frame& frame, const std::string& detection_json = {},
                               const std::vector<std::uint8_t>& overlay_png = {});

  [[nodiscard]] std::uint64_t bytes_on_disk() const { return total_bytes_; }
  [[nodiscard]] std::size_t recordings() const { return entries_.size(); }
  [[nodiscard]] const RecorderOptions& options() const { return options_; }

 private:
  struct Entry {
    std::string stem;  ///< file name stem, without folder
    std::uint64_t bytes = 0;
  };
  void prune();
  std::string next_stem(const Frame& frame);

  RecorderOptions options_;
  bool scanned_ = false;
  std::deque<Entry> entries_;  ///< oldest first
  std::uint64_t total_bytes_ = 0;
  std::uint64_t counter_ = 0;
};

}  // namespace palletd
