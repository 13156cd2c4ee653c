// The Aravis driver closed while the heartbeat thread of its device reports the control lost,
// against Aravis's own fake GigE Vision camera in a private network namespace (aravis_fake.hpp).
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include <arv.h>
#include <catch2/catch.hpp>

#include "palletd/drivers/camera.hpp"

#include "aravis_fake.hpp"

using namespace palletd;
using namespace palletd::test;
using std::chrono::milliseconds;

namespace {

/// Holds every "control-lost" emission open until `closed` is set (or 10 s pass): the heartbeat
/// thread holds its reference on the device for as long.
struct EmissionGate {
  std::mutex mutex;
  std::condition_variable changed;
  bool in_emission = false;
  bool closed = false;
};

gboolean hold_emission(GSignalInvocationHint* /*hint*/, guint /*n*/, const GValue* /*params*/,
                       gpointer data) {
  auto* gate = static_cast<EmissionGate*>(data);
  std::unique_lock<std::mutex> lock(gate->mutex);
  gate->in_emission = true;
  gate->changed.notify_all();
  gate->changed.wait_for(lock, std::chrono::seconds(10), [&] { return gate->closed; });
  return TRUE;
}

}  // namespace

// The camera powered off and on: the old device's heartbeat thread reads the new camera's
// control register, finds the control lost and emits "control-lost", holding a reference on the
// device. A close in that moment used to drop the camera's last other reference; the emission's
// then finalized the device in the heartbeat thread, which joined itself and GLib aborted the
// process (SIGTRAP). The hook holds the emission open so that the close falls inside it.
TEST_CASE("aravis camera closed while its heartbeat reports the control lost: the process lives") {
  SKIP_WITHOUT_NETNS();
  Fixture fx(1);
  auto fake = start_fake(fx.xml, fx.source, fx.replayed[0]);
  auto cam = make_camera(aravis_config("Coord3D_C16", false));
  REQUIRE(cam->open().ok());
  REQUIRE(cam->start().ok());
  REQUIRE(cam->grab(milliseconds(3000)).ok());
  EmissionGate gate;
  const guint signal = g_signal_lookup("control-lost", ARV_TYPE_DEVICE);
  REQUIRE(signal != 0);
  const gulong hook = g_signal_add_emission_hook(signal, 0, hold_emission, &gate, nullptr);
  fake.reset();
  fake = start_fake(fx.xml, fx.source, fx.replayed[0]);  // a new camera: no controller
  {
    std::unique_lock<std::mutex> lock(gate.mutex);
    REQUIRE(gate.changed.wait_for(lock, std::chrono::seconds(15), [&] { return gate.in_emission; }));
  }
  cam->close();
  {
    std::lock_guard<std::mutex> lock(gate.mutex);
    gate.closed = true;
  }
  gate.changed.notify_all();
  std::this_thread::sleep_for(milliseconds(500));  // the emission ends and drops its reference
  g_signal_remove_emission_hook(signal, hook);
  REQUIRE(cam->open().ok());  // the closed device is let go here, in this thread
  CHECK(cam->start().ok());
  CHECK(cam->grab(milliseconds(3000)).ok());
  cam.reset();
}
