// The Aravis driver's pixel conversions, without a camera.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>

#include "aravis/depth_convert.hpp"

using namespace palletd;
using namespace palletd::aravis;

TEST_CASE("Coord3D_C16 without offset keeps raw values and maps the scale to metres") {
  const std::vector<std::uint16_t> raw = {0, 1000, 65535, 4242, 7};
  Scan3dParams p;
  p.scale = 0.25;       // mm per unit
  p.unit_m = 0.001;
  p.invalid = 65535.0;
  Frame f;
  convert_c16(raw.data(), raw.size(), p, f);
  CHECK(f.depth_scale_m == Approx(0.00025));
  CHECK(f.depth == std::vector<std::uint16_t>{0, 1000, 0, 4242, 7});
}

TEST_CASE("Coord3D_C16 with an offset is converted to 0.1 mm units") {
  const std::vector<std::uint16_t> raw = {0, 100, 2000};
  Scan3dParams p;
  p.scale = 0.5;
  p.offset = 300.0;  // mm
  Frame f;
  convert_c16(raw.data(), raw.size(), p, f);
  CHECK(f.depth_scale_m == kQuantumM);
  CHECK(f.depth == std::vector<std::uint16_t>{0, 3500, 13000});  // 350 mm, 1300 mm
}

TEST_CASE("Coord3D_ABC32f takes Z, quantises to 0.1 mm and drops invalid points") {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> xyz = {1.f, 2.f, 1234.56f,  0.f, 0.f, 0.f,  5.f, 5.f, nan,
                                  0.f, 0.f, 7000.f,    0.f, 0.f, -3.f, 0.f, 0.f, 999.99f};
  std::vector<unsigned char> bytes(xyz.size() * sizeof(float) + 1);
  std::memcpy(bytes.data() + 1, xyz.data(), xyz.size() * sizeof(float));  // unaligned on purpose
  Scan3dParams p;
  Frame f;
  convert_abc32f(bytes.data() + 1, 6, p, f);
  CHECK(f.depth_scale_m == kQuantumM);
  CHECK(f.depth == std::vector<std::uint16_t>{12346, 0, 0, 0, 0, 10000});
}
