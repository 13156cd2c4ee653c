// The OpenNI2 driver on .oni files recorded from the palletd test device with openni::Recorder,
// detection through the device against replay, palletctl grab with an openni2 camera, and the
// pairing of depth and IR for a slow consumer.
#include "openni2_fixture.hpp"

using namespace palletd;
using namespace palletd::test;

TEST_CASE("openni2: frames recorded to .oni with openni::Recorder play back through the driver") {
  Source src(1);
  const std::string oni = (src.dir.path() / "rec.oni").string();
  const int recorded = record_oni(src.uri(), oni, 7);
  REQUIRE(recorded >= 7);

  // Once: every frame of the file, then the end of the recording.
  OpenNI2Options once = device_options(oni);
  once.loop = false;
  OpenNI2Camera cam(once);
  Status opened = cam.open();
  INFO(opened.error());
  REQUIRE(opened.ok());
  const int in_file = cam.recording_frame_count();
  CHECK(in_file >= recorded);
  CHECK(cam.identity().serial == "rec");
  REQUIRE(cam.start().ok());
  // Every depth frame of the file has its IR partner in the file (record_oni), and each one
  // arrives with it: the IR image of the same source frame.
  std::vector<Frame> pass;
  std::uint64_t drops_before_first = 0;  // file frames skipped before the first one delivered
  for (int i = 0; i < in_file + 1; ++i) {
    auto f = cam.grab(milliseconds(3000));
    if (!f.ok()) {
      INFO(f.error());
      CHECK(f.error().find("end of recording") != std::string::npos);
      break;
    }
    if (pass.empty()) drops_before_first = cam.counters().drops;
    const int k = match_source(*f, src.served);
    REQUIRE(k >= 0);
    CHECK(f->depth_scale_m == 0.001);
    INFO("frame " << i << " of the recording");
    REQUIRE(f->has_intensity());
    CHECK(f->intensity_bits == 8);
    CHECK(test::same_pixels(f->intensity, src.served[static_cast<std::size_t>(k)].intensity));
    CHECK(f->intrinsics.fx == Approx(src.served[0].intrinsics.fx).margin(2e-3));
    pass.push_back(std::move(*f));
  }
  CHECK(static_cast<int>(pass.size() + cam.counters().drops) == in_file);
  CHECK(cam.frames_without_ir() == 0);
  CHECK(cam.state() == CameraState::kStreaming);  // the end of a recording is no fault
  cam.close();

  // Looping: the file is reopened at its end and plays from its first frame again.
  OpenNI2Camera loop(device_options(oni));
  REQUIRE(loop.open().ok());
  REQUIRE(loop.start().ok());
  std::vector<Frame> first;
  bool rewound = false;
  std::uint64_t drops_in_first_pass = 0;
  for (int i = 0; i < 3 * in_file && !rewound; ++i) {
    const std::uint64_t drops_before = loop.counters().drops;
    auto f = loop.grab(milliseconds(3000));
    INFO(loop.last_error());
    REQUIRE(f.ok());
    const int k = match_source(*f, src.served);
    REQUIRE(k >= 0);
    REQUIRE(f->has_intensity());
    CHECK(test::same_pixels(f->intensity, src.served[static_cast<std::size_t>(k)].intensity));
    if (loop.rewinds() == 1) {
      rewound = true;
      drops_in_first_pass = drops_before;
      // The file's first frame again, unless a slow grab skipped it (then counted as a drop).
      if (drops_before_first == 0 && loop.counters().drops == drops_before) {
        CHECK(test::same_pixels(f->depth, pass.front().depth));
        CHECK(test::same_pixels(f->intensity, pass.front().intensity));
      }
    } else {
      first.push_back(std::move(*f));
    }
  }
  CHECK(rewound);
  CHECK(static_cast<int>(first.size() + drops_in_first_pass) == in_file);
  CHECK(loop.frames_without_ir() == 0);
  CHECK(loop.counters().faults == 0);
}

TEST_CASE("openni2: a frame through the device and through .oni gives the same detection as through replay") {
  Source src(1);
  const auto formats = test::recipe_formats(kXtion);
  DetectionParams params;
  auto replayed = read_frame(kXtion);
  REQUIRE(replayed.ok());
  const Detection want = detect(*replayed, formats, params);
  // The seams in the intensity image take part in the layout choice and the refinement: the frame
  // has to come with its own IR image.
  auto want_for = [&](const Frame& f) {
    REQUIRE(f.has_intensity());
    CHECK(test::same_pixels(f.intensity, replayed->intensity));
    return want;
  };

  auto xtion_from = [&](Camera& cam) {
    std::optional<Frame> f = grab_source(cam, src, 0);
    INFO("the xtion frame never came");
    REQUIRE(f.has_value());
    return std::move(*f);
  };

  // Device, 1 mm: the depth values are the replayed ones exactly; the intrinsics differ only by
  // the float field of view (< 1e-3 px), so the poses agree to 0.1 mm / 0.01 deg.
  OpenNI2Camera cam(device_options(src.uri()));
  REQUIRE(cam.open().ok());
  REQUIRE(cam.start().ok());
  Frame live = xtion_from(cam);
  CHECK(test::same_pixels(live.depth, replayed->depth));
  live.T_base_camera = replayed->T_base_camera;  // calibration is the cell's, not the camera's
  test::require_same_detection(detect(live, formats, params), want_for(live), 1e-4, 0.01);
  cam.close();

  // Through an .oni file: the same.
  const std::string oni = (src.dir.path() / "det.oni").string();
  record_oni(src.uri(), oni, 7);
  OpenNI2Camera player(device_options(oni));
  REQUIRE(player.open().ok());
  REQUIRE(player.start().ok());
  Frame played = xtion_from(player);
  CHECK(test::same_pixels(played.depth, replayed->depth));
  played.T_base_camera = replayed->T_base_camera;
  test::require_same_detection(detect(played, formats, params), want_for(played), 1e-4, 0.01);
}

TEST_CASE("openni2: a 0.2 mm frame quantised to 1 mm gives the same boxes within 2 mm / 0.2 deg") {
  // The blaze frame carries 0.2 mm units; a 1 mm OpenNI depth mode rounds every pixel by up to
  // 0.5 mm. The plane fit averages that out, the outline moves by at most a quantisation step,
  // so box centres stay within 2 mm and angles within 0.2 deg of replay's.
  Source src(2);
  const auto formats = test::recipe_formats(kBlaze);
  DetectionParams params;
  auto replayed = read_frame(kBlaze);
  REQUIRE(replayed.ok());
  const Detection want = detect(*replayed, formats, params);
  OpenNI2Camera cam(device_options(src.uri(), 0.001));
  REQUIRE(cam.open().ok());
  REQUIRE(cam.start().ok());
  std::optional<Frame> f = grab_source(cam, src, 0);
  INFO("the blaze frame never came");
  REQUIRE(f.has_value());
  CHECK(f->depth_scale_m == 0.001);
  f->intrinsics = replayed->intrinsics;  // compare the depth path alone
  f->T_base_camera = replayed->T_base_camera;
  test::require_same_detection(detect(*f, formats, params), want, 0.002, 0.2);
}

TEST_CASE("openni2: palletctl grab --config with an openni2 camera writes the frames") {
  Source src(1);
  const fs::path yaml = src.dir.path() / "openni2.yaml";
  std::ofstream(yaml) << "camera:\n  driver: openni2\n  openni2:\n    uri: \"" << src.uri() << "\"\n";
  const fs::path out = src.dir.path() / "grab";
  const fs::path log = src.dir.path() / "palletctl.out";
  const std::string cmd = "LD_LIBRARY_PATH=" + std::string(PALLETD_ONI_RUNTIME) + " " + PALLETD_BINARY_DIR +
                          "/src/palletctl/palletctl grab --config " + yaml.string() + " -n 3 --out " + out.string() +
                          " > " + log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  INFO(text);
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);
  auto stems = list_frame_stems(out.string());
  REQUIRE(stems.ok());
  REQUIRE(stems->size() == 3);
  for (const auto& stem : *stems) {
    auto f = read_frame(stem);
    REQUIRE(f.ok());
    CHECK(match_source(*f, src.served) >= 0);
    CHECK(f->has_intensity());
  }
}

TEST_CASE("openni2: a consumer slower than the frame rate still gets each depth frame's own IR") {
  // Grabs three frame periods apart: the old wait-for-the-next-IR-frame pairing found the IR
  // stream already past the depth frame here and delivered it without intensity.
  Source src(1);
  OpenNI2Camera cam(device_options(src.uri()));
  REQUIRE(cam.open().ok());
  REQUIRE(cam.start().ok());
  for (int i = 0; i < 6; ++i) {
    std::this_thread::sleep_for(milliseconds(100));
    auto f = cam.grab(milliseconds(3000));
    INFO(cam.last_error());
    REQUIRE(f.ok());
    const int k = match_source(*f, src.served);
    REQUIRE(k >= 0);
    REQUIRE(f->has_intensity());
    CHECK(test::same_pixels(f->intensity, src.served[static_cast<std::size_t>(k)].intensity));
  }
  CHECK(cam.frames_without_ir() == 0);
  CHECK(cam.counters().drops > 0);  // the newest frame each time: the ones in between are skipped
  REQUIRE(cam.stop().ok());
  // Stopped and started again: no frame of before the stop is delivered, pairing goes on.
  REQUIRE(cam.start().ok());
  grab_and_match(cam, src, 3, 0.001, true);
  cam.close();
}
