// The OpenNI2 driver through the real OpenNI2 runtime, against the palletd test device
// (openni2_test_device.cpp, loaded from the private runtime folder PALLETD_ONI_RUNTIME). Through
// .oni files recorded from it with openni::Recorder: test_openni2_oni.cpp.
#include "openni2_fixture.hpp"

using namespace palletd;
using namespace palletd::test;

TEST_CASE("openni2: the test device through the runtime gives the source frames in mm - with IR") {
  Source src(1);
  OpenNI2Camera cam(device_options(src.uri()));
  REQUIRE(cam.state() == CameraState::kClosed);
  Status opened = cam.open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  const CameraIdentity id = cam.identity();
  CHECK(id.driver == "openni2");
  CHECK(id.vendor == "palletd");
  CHECK(id.serial == "PDONI01");
  CHECK(id.address == src.uri());
  REQUIRE(cam.start().ok());
  const auto idx = grab_and_match(cam, src, 7, 0.001, true);
  // The xtion frame (the one in mm) arrives with its own depth values, unchanged.
  auto f = cam.grab(milliseconds(3000));
  REQUIRE(f.ok());
  const int k = match_source(*f, src.served);
  REQUIRE(k >= 0);
  CHECK(test::same_pixels(f->depth, src.served[static_cast<std::size_t>(k)].depth));
  // Intrinsics from the device's field of view: the source's fx/fy (through a float FOV), the
  // principal point at the centre of the pixel grid.
  const Intrinsics& want = src.served[0].intrinsics;
  CHECK(f->intrinsics.width == 640);
  CHECK(f->intrinsics.fx == Approx(want.fx).margin(2e-3));
  CHECK(f->intrinsics.fy == Approx(want.fy).margin(2e-3));
  CHECK(f->intrinsics.cx == 319.5);
  CHECK(f->intrinsics.cy == 239.5);
  CHECK(f->camera_id == id.id());
  CHECK(cam.counters().frames == 8);
  REQUIRE(cam.stop().ok());
  cam.close();
  CHECK(cam.state() == CameraState::kClosed);
  (void)idx;
}

TEST_CASE("openni2: 100 um mode - first device - configured intrinsics") {
  Source src(2);
  ::setenv("PALLETD_OPENNI2_TEST_FRAMES", src.frames.string().c_str(), 1);
  OpenNI2Options o = device_options("", 0.0001);  // the first device: the one announced
  Intrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 500.0;
  k.cx = 320.0;
  k.cy = 240.0;
  o.intrinsics_override = k;
  OpenNI2Camera cam(o);
  Status opened = cam.open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  CHECK(cam.identity().address == src.uri());
  REQUIRE(cam.start().ok());
  grab_and_match(cam, src, 4, 0.0001, true);
  auto f = cam.grab(milliseconds(3000));
  REQUIRE(f.ok());
  CHECK(f->intrinsics.fx == 500.0);
  CHECK(f->intrinsics.cx == 320.0);
  // The blaze frame (0.2 mm units) arrives as exactly twice its values in 100 um units.
  const int m = match_source(*f, src.served);
  REQUIRE(m >= 0);
  const Frame& s = src.served[static_cast<std::size_t>(m)];
  if (s.depth_scale_m == 0.0002) {
    bool doubled = true;
    for (std::size_t i = 0; i < s.depth.size(); ++i) doubled = doubled && f->depth[i] == 2 * s.depth[i];
    CHECK(doubled);
  }
  cam.close();
  ::unsetenv("PALLETD_OPENNI2_TEST_FRAMES");
}

TEST_CASE("openni2: errors are values naming what failed") {
  Source src(1);
  {
    OpenNI2Camera cam(device_options("palletd-test:///no/such/folder"));
    Status st = cam.open();
    CHECK_FALSE(st.ok());
    CHECK(st.error().find("/no/such/folder") != std::string::npos);
    CHECK(cam.state() == CameraState::kClosed);
    CHECK_FALSE(cam.grab(milliseconds(10)).ok());
  }
  {
    OpenNI2Camera cam(device_options("/no/such/recording.oni"));
    Status st = cam.open();
    CHECK_FALSE(st.ok());
    CHECK(st.error().find("/no/such/recording.oni") != std::string::npos);
  }
  {
    OpenNI2Options o = device_options(src.uri());
    o.width = 1280;
    o.height = 1024;
    OpenNI2Camera cam(o);
    Status st = cam.open();
    CHECK_FALSE(st.ok());
    INFO(st.error());
    CHECK(st.error().find("1280x1024@30 1mm") != std::string::npos);
    CHECK(st.error().find("640x480@30 100um") != std::string::npos);  // what the device offers
  }
  {
    CameraConfig config;
    config.driver = "openni2";
    config.openni2.depth_unit_m = 0.0005;
    CHECK_THROWS_AS(make_camera(config), std::invalid_argument);
    config.openni2.depth_unit_m = 0.001;
    config.openni2.uri = src.uri();
    auto cam = make_camera(config);
    REQUIRE(cam);
    CHECK(cam->identity().driver == "openni2");
    REQUIRE(cam->open().ok());
    REQUIRE(cam->start().ok());
    CHECK(cam->grab(milliseconds(3000)).ok());
  }
}
