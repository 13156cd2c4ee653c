// Depth/IR pairing for the OpenNI2 driver (openni2_camera.cpp): two small rings of recent frames,
// filled from OpenNI's frame callbacks (any thread), emptied by the acquisition thread. Private
// header; no OpenNI type here, so the pairing rules are tested on their own
// (tests/drivers/test_openni2_pairing.cpp).
//
// Rules:
// - take_depth() gives the newest depth frame not taken yet (waiting for one until a deadline)
//   and discards older ones: a consumer slower than the frame rate gets fresh frames, the skipped
//   ones show as gaps in the frame index (the driver counts them as drops).
// - take_ir_partner() gives the IR frame whose device timestamp is nearest the depth frame's, if
//   it lies within a tolerance (half a frame period). It waits for IR frames still to come, until
//   a deadline, but not once the IR stream has passed the depth frame's instant (the streams
//   deliver in timestamp order, so the partner was lost or never sent). IR frames older than the
//   taken depth frame can pair with no later depth frame and are discarded.
// - Each ring holds at most `capacity` frames; the oldest goes first. Frames leave the rings (and
//   are released) outside the lock, so a frame's release may call into the vendor library.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace palletd::openni2 {

/// `Held` is what a frame entry keeps alive (an openni::VideoFrameRef in the driver).
template <typename Held>
class FramePairing {
 public:
  using Clock = std::chrono::steady_clock;
  enum class Stream { kDepth, kIr };
  struct Entry {
    std::uint64_t timestamp_us = 0;  ///< device timestamp [us]
    int index = 0;                   ///< device frame index
    std::shared_ptr<const Held> frame;
  };

  explicit FramePairing(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}
  FramePairing(const FramePairing&) = delete;
  FramePairing& operator=(const FramePairing&) = delete;
  ~FramePairing() { clear(); }

  /// Any thread: a frame arrived.
  void push(Stream stream, Entry entry) {
    std::vector<Entry> gone;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      std::deque<Entry>& ring = stream == Stream::kDepth ? depth_ : ir_;
      ring.push_back(std::move(entry));
      while (ring.size() > capacity_) {
        gone.push_back(std::move(ring.front()));
        ring.pop_front();
      }
    }
    cv_.notify_all();
  }

  /// The newest depth frame not taken yet; waits for one until `deadline` (nullopt then).
  std::optional<Entry> take_depth(Clock::time_point deadline) {
    std::deque<Entry> gone;
    std::optional<Entry> out;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (!cv_.wait_until(lock, deadline, [this] { return !depth_.empty(); })) return std::nullopt;
      out = std::move(depth_.back());
      depth_.pop_back();
      gone.swap(depth_);
    }
    return out;
  }

  /// The IR frame within `tolerance_us` of `timestamp_us` (the nearest), waiting for it until
  /// `deadline` while it can still come; nullopt when there is none.
  std::optional<Entry> take_ir_partner(std::uint64_t timestamp_us, std::uint64_t tolerance_us,
                                       Clock::time_point deadline) {
    std::vector<Entry> gone;
    std::optional<Entry> out;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      auto decided = [&] {
        // Drop what can pair with neither this nor a later depth frame.
        while (!ir_.empty() && ir_.front().timestamp_us + tolerance_us < timestamp_us) {
          gone.push_back(std::move(ir_.front()));
          ir_.pop_front();
        }
        std::size_t best = ir_.size();
        std::uint64_t best_dt = 0;
        for (std::size_t i = 0; i < ir_.size(); ++i) {
          const std::uint64_t t = ir_[i].timestamp_us;
          const std::uint64_t dt = t > timestamp_us ? t - timestamp_us : timestamp_us - t;
          if (dt <= tolerance_us && (best == ir_.size() || dt < best_dt)) {
            best = i;
            best_dt = dt;
          }
        }
        if (best < ir_.size()) {
          out = std::move(ir_[best]);
          for (std::size_t i = 0; i <= best; ++i) {  // the partner and every IR frame before it
            if (i < best) gone.push_back(std::move(ir_.front()));
            ir_.pop_front();
          }
          return true;
        }
        // The IR stream is past this instant: the partner will not come.
        return !ir_.empty() && ir_.back().timestamp_us > timestamp_us + tolerance_us;
      };
      cv_.wait_until(lock, deadline, decided);
    }
    return out;
  }

  /// Frames held in each ring (for tests).
  [[nodiscard]] std::pair<std::size_t, std::size_t> sizes() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return {depth_.size(), ir_.size()};
  }

  /// Drops every frame (before the streams they came from go away).
  void clear() {
    std::deque<Entry> depth, ir;
    std::lock_guard<std::mutex> lock(mutex_);
    depth.swap(depth_);
    ir.swap(ir_);
    // Released after the lock (declared before the guard, destroyed after it).
  }

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Entry> depth_;  ///< guarded by mutex_; oldest first
  std::deque<Entry> ir_;     ///< guarded by mutex_; oldest first
};

}  // namespace palletd::openni2
