// The service's recording of triggered frames with their results (recording section): every
// trigger, or the next one after SaveSnapshot. A full or read-only disk is counted and reported,
// never passed on to the detection or the PLC.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "palletd/config/config.hpp"
#include "palletd/frames/recorder.hpp"
#include "palletd/status/snapshot.hpp"

namespace palletd {

class ResultRecording {
 public:
  /// Null options: recording is off (snapshots are refused).
  explicit ResultRecording(const Config& cfg);

  [[nodiscard]] bool enabled() const { return recorder_ != nullptr; }
  /// SaveSnapshot: the next result is recorded. Any thread.
  void ask() { asked_ = true; }
  /// Pipeline thread: records `snapshot` when asked or when every trigger is recorded.
  void after_result(const Config& cfg, const ResultSnapshot& snapshot);

  [[nodiscard]] std::uint64_t recordings() const { return recordings_.load(); }
  [[nodiscard]] std::uint64_t failures() const { return failures_.load(); }
  [[nodiscard]] std::string last_error() const;

 private:
  std::unique_ptr<FrameRecorder> recorder_;  ///< pipeline thread only
  std::atomic<bool> asked_{false};
  std::atomic<std::uint64_t> recordings_{0}, failures_{0};
  mutable std::mutex error_mutex_;
  std::string last_error_;  ///< guarded by error_mutex_
};

}  // namespace palletd
