// The acquisition thread's frame for a trigger (src/service/acquisition.hpp), on a scripted
// free-running camera: frames that arrived before the trigger never answer it.
#include <atomic>
#include <chrono>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

#include <catch2/catch.hpp>

#include "palletd/drivers/camera.hpp"

#include "acquisition.hpp"

using namespace palletd;
using namespace std::chrono_literals;

namespace {

std::int64_t system_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// Free-running: serves the frames queued (as a stream's full buffer queue holds them), then a
/// fresh frame every 20 ms stamped on arrival, like the drivers.
class ScriptedCamera : public Camera {
 public:
  void queue_stale(int n, std::chrono::milliseconds age) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (int i = 0; i < n; ++i) queued_.push_back(system_ns() - std::chrono::nanoseconds(age).count());
  }
  [[nodiscard]] bool trigger_mode() const override { return false; }
  [[nodiscard]] std::uint64_t grabs() const { return grabs_.load(); }

 protected:
  Status do_open() override {
    set_identity(CameraIdentity{"scripted", "palletd", "script", "1", ""});
    return {};
  }
  Status do_start() override { return {}; }
  Status do_stop() override { return {}; }
  void do_close() override {}
  Expected<Frame> do_grab(std::chrono::milliseconds /*timeout*/) override {
    grabs_.fetch_add(1);
    Frame f;
    f.intrinsics.width = 4;
    f.intrinsics.height = 3;
    f.depth.assign(12, 1000);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!queued_.empty()) {
        f.timestamp_ns = queued_.front();
        queued_.pop_front();
        return f;
      }
    }
    std::this_thread::sleep_for(20ms);
    f.timestamp_ns = system_ns();
    return f;
  }

 private:
  std::mutex mutex_;
  std::deque<std::int64_t> queued_;  ///< arrival times of frames waiting in the stream's queue
  std::atomic<std::uint64_t> grabs_{0};
};

/// The scripted camera under an acquisition thread that has answered one trigger (streaming).
struct Streaming {
  std::unique_ptr<ScriptedCamera> owned = std::make_unique<ScriptedCamera>();
  ScriptedCamera& script = *owned;
  Acquisition acquisition{std::make_unique<CameraSupervisor>(std::move(owned), 0.1, 0.4), nullptr};
  Streaming() {
    acquisition.start();
    REQUIRE(acquisition.frame_after(std::chrono::steady_clock::now(), 2000ms).ok());
  }
};

}  // namespace

TEST_CASE("a trigger is answered by a frame that arrived after it, however many wait in the queue") {
  Streaming streaming;
  ScriptedCamera& script = streaming.script;
  Acquisition& acquisition = streaming.acquisition;
  // Between triggers the stream's buffers filled up with frames the idle loop has not taken yet.
  script.queue_stale(6, 300ms);
  const std::int64_t trigger_ns = system_ns();
  const Expected<Frame> frame = acquisition.frame_after(std::chrono::steady_clock::now(), 2000ms);
  REQUIRE(frame.ok());
  CHECK(frame->timestamp_ns >= trigger_ns);
}

TEST_CASE("between triggers a free-running camera's frames are all taken as they come") {
  // A frame every 20 ms: left waiting, a stream's few buffers fill and the camera's next frames
  // are dropped (counted as lost on the status page and in the registers).
  Streaming streaming;
  ScriptedCamera& script = streaming.script;
  const std::uint64_t before = script.grabs();
  std::this_thread::sleep_for(1000ms);
  const std::uint64_t taken = script.grabs() - before;
  INFO(taken << " frames taken in 1 s of 50");
  CHECK(taken >= 25);  // one per 100 ms (10) when the idle loop paused between grabs
}
