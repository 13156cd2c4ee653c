// The Aravis driver tests' fake GigE Vision camera (ArvGvFakeCamera on loopback): its GenICam
// XML with the 3D pixel formats and Scan3d features, a fill callback serving frames, the frames
// also written to a replay folder, and the driver's configuration for it.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <arv.h>

#include "palletd/config/config.hpp"
#include "palletd/core/frame.hpp"

#include "drivers_test_util.hpp"
#include "netns.hpp"

namespace palletd::test {

/// What the fake camera's fill callback serves: the frames in turn.
struct FakeSource {
  std::mutex mutex;
  std::vector<Frame> frames;
  std::size_t next = 0;
  std::size_t served = 0;
};

using FakeGvPtr = std::unique_ptr<ArvGvFakeCamera, void (*)(ArvGvFakeCamera*)>;

/// A fake camera at 127.0.0.1 (serial PD3D01) whose frames come from `source`, sized as `shape`.
FakeGvPtr start_fake(const std::string& xml, FakeSource& source, const Frame& shape);

/// Frames, written to a replay folder and read back through the replay driver.
struct Fixture {
  TempDir dir{"aravis"};
  std::string xml;
  FakeSource source;
  std::vector<Frame> replayed;

  explicit Fixture(int count);
};

/// The Aravis driver's configuration for the fake camera.
CameraConfig aravis_config(const std::string& format, bool trigger);

}  // namespace palletd::test

#define SKIP_WITHOUT_NETNS()                                                      \
  do {                                                                            \
    const std::string why = palletd::test::enter_private_netns();                 \
    if (!why.empty()) {                                                           \
      WARN("skipped: no private network namespace for the fake camera: " << why); \
      SUCCEED("skipped: " << why);                                                \
      return;                                                                     \
    }                                                                             \
  } while (false)
