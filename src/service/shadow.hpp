// palletd service (private): the shadow configuration (`shadow_config:`). A second configuration
// runs on every triggered frame after the live result is published, on a thread of its own at
// idle priority: it never delays a result or the next trigger, writes no register, and takes a
// core only when the live pipeline leaves one free. Disagreements with the live result are
// counted (ServiceHealth, metrics, status page), logged, and their frames recorded with the live
// result so `palletctl compare` replays them.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "palletd/config/config.hpp"
#include "palletd/frames/recorder.hpp"
#include "palletd/status/snapshot.hpp"

namespace palletd {

struct ShadowCounters {
  bool enabled = false;             ///< a shadow configuration is in force
  std::uint64_t runs = 0;           ///< frames the shadow configuration detected
  std::uint64_t disagreements = 0;  ///< of those, results that differ from the live one
  std::uint64_t skipped = 0;        ///< frames not run: the shadow was busy, or its recipe is missing
  std::string last_difference;      ///< "trigger 12: boxes 12 -> 11", "" before the first
};

class ShadowRunner {
 public:
  /// `record` (optional): where frames of disagreements are recorded.
  ShadowRunner(std::shared_ptr<const Config> shadow, std::optional<RecorderOptions> record, double moved_mm);
  ~ShadowRunner();  ///< stop()s
  /// Ends the thread (a running detection finishes first); counters() stays valid. Idempotent.
  void stop();
  ShadowRunner(const ShadowRunner&) = delete;
  ShadowRunner& operator=(const ShadowRunner&) = delete;
  ShadowRunner(ShadowRunner&&) = delete;
  ShadowRunner& operator=(ShadowRunner&&) = delete;

  /// The shadow configuration from now on (null: off). Any thread.
  void set_config(std::shared_ptr<const Config> shadow);
  /// Hands over a published live result whose detection ran; replaces one still waiting (that
  /// one is counted as skipped). Returns at once. Any thread.
  void submit(std::shared_ptr<const ResultSnapshot> live);
  [[nodiscard]] ShadowCounters counters() const;

 private:
  void run();
  void compare(const ResultSnapshot& live, const Config& shadow);

  const double moved_mm_;
  std::unique_ptr<FrameRecorder> recorder_;  ///< shadow thread only
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::shared_ptr<const Config> config_;       ///< guarded by mutex_
  std::shared_ptr<const ResultSnapshot> job_;  ///< guarded by mutex_
  bool stopping_ = false;                      ///< guarded by mutex_
  ShadowCounters counters_;                    ///< guarded by mutex_
  std::thread thread_;
};

/// The service's shadow runner for `config`: its shadow_config; the frames it disagrees on recorded
/// in a ring beside the recordings, an eighth of their size (when recording is on); a box counts
/// as moved beyond 5 mm.
std::unique_ptr<ShadowRunner> make_shadow(const Config& config);

}  // namespace palletd
