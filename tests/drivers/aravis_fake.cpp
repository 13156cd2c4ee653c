// The Aravis driver tests' fake GigE Vision camera (aravis_fake.hpp).
#include "aravis_fake.hpp"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <catch2/catch.hpp>

#include "palletd/drivers/camera.hpp"
#include "palletd/frames/frame_io.hpp"

using std::chrono::milliseconds;

namespace palletd::test {
namespace {

constexpr std::uint32_t kScaleAddr = 0x8000;  // doubles, big-endian
constexpr std::uint32_t kOffsetAddr = 0x8008;
constexpr std::uint32_t kFocalAddr = 0x8010;
constexpr std::uint32_t kPpuAddr = 0x8018;
constexpr std::uint32_t kPpvAddr = 0x8020;
constexpr std::uint32_t kInvalidAddr = 0x8028;

std::string float_feature(const std::string& name, std::uint32_t address) {
  char addr[16];
  std::snprintf(addr, sizeof addr, "0x%x", address);
  return "\t<Float Name=\"" + name + "\" NameSpace=\"Standard\">\n\t\t<pValue>" + name +
         "Reg</pValue>\n\t</Float>\n\t<FloatReg Name=\"" + name +
         "Reg\" NameSpace=\"Custom\">\n\t\t<Address>" + addr +
         "</Address>\n\t\t<Length>8</Length>\n\t\t<AccessMode>RW</AccessMode>\n"
         "\t\t<pPort>Device</pPort>\n\t\t<Endianess>BigEndian</Endianess>\n\t</FloatReg>\n";
}

/// The fake camera's own GenICam XML plus the 3D pixel formats and Scan3d features.
std::string write_genicam_xml(const TempDir& dir) {
  ArvFakeCamera* probe = arv_fake_camera_new("PROBE");
  size_t size = 0;
  const char* text = arv_fake_camera_get_genicam_xml(probe, &size);
  std::string xml(text, size);
  g_object_unref(probe);

  const std::string anchor = "<pValue>PixelFormatRegister</pValue>";
  const auto at = xml.find(anchor);
  REQUIRE(at != std::string::npos);
  xml.insert(at, "<EnumEntry Name=\"Coord3D_C16\" NameSpace=\"Standard\"><Value>" +
                     std::to_string(ARV_PIXEL_FORMAT_COORD3D_C_16) + "</Value></EnumEntry>\n\t\t" +
                     "<EnumEntry Name=\"Coord3D_ABC32f\" NameSpace=\"Standard\"><Value>" +
                     std::to_string(ARV_PIXEL_FORMAT_COORD3D_ABC_32F) + "</Value></EnumEntry>\n\t\t");
  std::string features =
      float_feature("Scan3dCoordinateScale", kScaleAddr) +
      float_feature("Scan3dCoordinateOffset", kOffsetAddr) + float_feature("Scan3dFocalLength", kFocalAddr) +
      float_feature("Scan3dPrincipalPointU", kPpuAddr) + float_feature("Scan3dPrincipalPointV", kPpvAddr) +
      float_feature("Scan3dInvalidDataValue", kInvalidAddr);
  const auto port = xml.find("<Port Name=\"Device\"");
  REQUIRE(port != std::string::npos);
  xml.insert(port, features);
  std::string path = (dir.path() / "fake-3d.xml").string();
  std::ofstream(path) << xml;
  return path;
}

void write_double(ArvFakeCamera* camera, std::uint32_t address, double value) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof bits);
  bits = __builtin_bswap64(bits);
  REQUIRE(arv_fake_camera_write_memory(camera, address, sizeof bits, &bits));
}

void fill(ArvBuffer* buffer, void* data, guint32 /*exposure_us*/, guint32 /*gain*/, ArvPixelFormat format) {
  auto* source = static_cast<FakeSource*>(data);
  std::lock_guard<std::mutex> lock(source->mutex);
  if (source->frames.empty()) return;
  const Frame& f = source->frames[source->next++ % source->frames.size()];
  ++source->served;
  // The fake camera's buffer reports size 0 to the callback; it holds PayloadSize bytes,
  // which is Width x Height x bytes per pixel (the registers were set to the frame's size).
  size_t size = 0;
  auto* out = static_cast<unsigned char*>(const_cast<void*>(arv_buffer_get_data(buffer, &size)));
  if (arv_buffer_get_image_width(buffer) != f.intrinsics.width ||
      arv_buffer_get_image_height(buffer) != f.intrinsics.height) {
    return;
  }
  const std::size_t n = f.pixel_count();
  if (format == ARV_PIXEL_FORMAT_COORD3D_ABC_32F) {
    for (std::size_t i = 0; i < n; ++i) {
      const int u = static_cast<int>(i % static_cast<std::size_t>(f.intrinsics.width));
      const int v = static_cast<int>(i / static_cast<std::size_t>(f.intrinsics.width));
      const float z_mm = static_cast<float>(f.depth[i]);  // frames are in millimetres
      const float xyz[3] = {static_cast<float>((u - f.intrinsics.cx) * z_mm / f.intrinsics.fx),
                            static_cast<float>((v - f.intrinsics.cy) * z_mm / f.intrinsics.fy),
                            f.depth[i] == 0 ? std::nanf("") : z_mm};
      std::memcpy(out + i * 12, xyz, sizeof xyz);
    }
  } else {
    std::memcpy(out, f.depth.data(), n * 2);
  }
}

}  // namespace

FakeGvPtr start_fake(const std::string& xml, FakeSource& source, const Frame& shape) {
  FakeGvPtr fake(arv_gv_fake_camera_new_full("127.0.0.1", "PD3D01", xml.c_str()),
                 [](ArvGvFakeCamera* p) { g_object_unref(p); });
  REQUIRE(fake);
  REQUIRE(arv_gv_fake_camera_is_running(fake.get()));
  ArvFakeCamera* cam = arv_gv_fake_camera_get_fake_camera(fake.get());
  arv_fake_camera_write_register(cam, ARV_FAKE_CAMERA_REGISTER_WIDTH,
                                 static_cast<guint32>(shape.intrinsics.width));
  arv_fake_camera_write_register(cam, ARV_FAKE_CAMERA_REGISTER_HEIGHT,
                                 static_cast<guint32>(shape.intrinsics.height));
  write_double(cam, kScaleAddr, 1.0);  // millimetres per unit, as the frames
  write_double(cam, kOffsetAddr, 0.0);
  write_double(cam, kFocalAddr, shape.intrinsics.fx);
  write_double(cam, kPpuAddr, shape.intrinsics.cx);
  write_double(cam, kPpvAddr, shape.intrinsics.cy);
  write_double(cam, kInvalidAddr, 0.0);
  arv_fake_camera_set_fill_pattern(cam, fill, &source);
  return fake;
}

Fixture::Fixture(int count) {
  xml = write_genicam_xml(dir);
  const auto frames_dir = dir.path() / "frames";
  std::filesystem::create_directories(frames_dir);
  for (int i = 0; i < count; ++i) {
    REQUIRE(write_frame((frames_dir / ("f" + std::to_string(i))).string(),
                        synthetic_frame(96, 72, static_cast<std::uint32_t>(20 + i)))
                .ok());
  }
  CameraConfig rc;
  rc.driver = "replay";
  rc.replay.directory = frames_dir.string();
  rc.replay.loop = false;
  auto replay = make_camera(rc);
  REQUIRE(replay->open().ok());
  REQUIRE(replay->start().ok());
  for (int i = 0; i < count; ++i) {
    REQUIRE(replay->software_trigger().ok());
    auto f = replay->grab(milliseconds(500));
    REQUIRE(f.ok());
    replayed.push_back(f.value());
  }
  source.frames = replayed;
}

CameraConfig aravis_config(const std::string& format, bool trigger) {
  CameraConfig c;
  c.driver = "aravis";
  c.aravis.address = "127.0.0.1";
  c.aravis.pixel_format = format;
  c.aravis.software_trigger = trigger;
  c.aravis.packet_size = 1400;
  c.aravis.buffer_count = 4;
  c.reconnect_min_s = 0.1;
  c.reconnect_max_s = 0.4;
  return c;
}

}  // namespace palletd::test
