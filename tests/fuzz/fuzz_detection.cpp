// Fuzz target: detection (detect(), the whole pipeline) on mutated frames.
// The bundled small frames (tests/data/*-small) are loaded once; the input picks one and applies
// up to 24 mutations of 8 bytes each: rectangles set to a depth, to 0 (no measurement), to noise or
// to a tilted plane (a wall); depth scale, intrinsics and the box formats bent, zeroed or negated.
// Oracle: no crash or sanitizer report; a status for every outcome (and a message unless ok);
// ok means boxes with finite poses; each call within a time bound (libFuzzer's -timeout as well).
#include <algorithm>
#include <ctime>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "fuzz_util.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/frames/frame_io.hpp"

using namespace palletd;
using fuzz::fail;

namespace {

struct Base {
  Frame frame;
  std::vector<BoxFormat> formats;
};

std::vector<Base> load_bases() {
  std::vector<Base> bases;
  for (const char* name : {"02_block_400x300_ind_o3d303-small", "05_brick_300x200_o3d303-small",
                           "17_pinwheel_315x232_o3d303-small", "19_block_315x232_nopallet_o3d303-small"}) {
    const std::string stem = std::string(PALLETD_TEST_DATA_DIR) + "/" + name;
    auto frame = read_frame(stem);
    auto truth = read_truth(stem);
    if (!frame || !truth) fail("cannot load " + stem);
    Base b{std::move(*frame), {}};
    for (std::size_t i = 0; i < truth->recipe_mm.size(); ++i) {
      b.formats.push_back({truth->recipe_mm[i][0] / 1000.0, truth->recipe_mm[i][1] / 1000.0,
                           truth->recipe.size() > i ? truth->recipe[i] : "F" + std::to_string(i)});
    }
    bases.push_back(std::move(b));
  }
  return bases;
}

/// A factor from one byte: 0, negative, tiny, ~1, huge, NaN or infinity.
double factor(std::uint8_t b) {
  switch (b % 8) {
    case 0: return 0.0;
    case 1: return -1.0;
    case 2: return 1e-6;
    case 3: return 1e6;
    case 4: return std::numeric_limits<double>::quiet_NaN();
    case 5: return std::numeric_limits<double>::infinity();
    default: return 0.5 + b / 128.0;  // 0.5 .. 2.5
  }
}

void mutate(Frame& f, std::vector<BoxFormat>& formats, fuzz::ByteReader& in) {
  const std::uint8_t op = in.u8();
  const int w = f.intrinsics.width, h = f.intrinsics.height;
  const int x0 = in.u8() * w / 256, y0 = in.u8() * h / 256;
  const int x1 = std::min(w, x0 + 1 + in.u8() * w / 256), y1 = std::min(h, y0 + 1 + in.u8() * h / 256);
  const std::uint16_t value = in.u16();
  const std::uint8_t extra = in.u8();
  auto rect = [&](auto&& fn) {
    if (f.depth.size() != f.pixel_count()) return;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) fn(f.depth[static_cast<std::size_t>(y * w + x)], x, y);
  };
  std::uint32_t noise = value | (static_cast<std::uint32_t>(extra) << 16) | 1u;
  switch (op % 12) {
    case 0: rect([&](std::uint16_t& d, int, int) { d = value; }); break;
    case 1: rect([&](std::uint16_t& d, int, int) { d = 0; }); break;
    case 2:  // noise of amplitude `extra`
      rect([&](std::uint16_t& d, int, int) {
        noise = noise * 1664525u + 1013904223u;
        d = static_cast<std::uint16_t>(d + (noise >> 24) % (extra + 1u) - extra / 2u);
      });
      break;
    case 3:  // a tilted plane (a wall, a ramp)
      rect([&](std::uint16_t& d, int x, int y) {
        d = static_cast<std::uint16_t>(value + (x - x0) * (extra - 128) + (y - y0) * static_cast<int>(op));
      });
      break;
    case 4: f.depth_scale_m *= factor(extra); break;
    case 5: f.intrinsics.fx *= factor(extra); break;
    case 6: f.intrinsics.fy *= factor(extra); break;
    case 7:
      f.intrinsics.cx += (value - 32768) / 64.0;
      f.intrinsics.cy += (extra - 128) / 2.0;
      break;
    case 8:
      if (!formats.empty()) {
        BoxFormat& b = formats[extra % formats.size()];
        b.long_m *= factor(static_cast<std::uint8_t>(value));
        b.short_m *= factor(static_cast<std::uint8_t>(value >> 8));
      }
      break;
    case 9:
      if (extra % 4 == 0) formats.clear();
      else if (formats.size() < 8) formats.push_back({value / 10000.0, extra / 1000.0, "fuzz"});
      break;
    case 10:  // distortion, sometimes absurd
      f.intrinsics.distortion = std::array<double, 5>{(value - 32768) / 32768.0, factor(extra) * 0.1, 0.0, 0.0, 0.0};
      break;
    default:  // the whole frame at another distance
      for (std::uint16_t& d : f.depth) d = static_cast<std::uint16_t>(d * (extra + 1) / 64);
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::vector<Base> bases = load_bases();
  fuzz::ByteReader in(data, size);
  const Base& base = bases[in.u8() % bases.size()];
  Frame frame = base.frame;
  std::vector<BoxFormat> formats = base.formats;
  for (int i = 0; i < 24 && in.remaining() > 0; ++i) mutate(frame, formats, in);

  // Bounded time, as processor time (the fuzzer may share a busy machine): the layout search has a
  // 50 ms budget, so seconds here mean a stage without a bound.
  const std::clock_t start = std::clock();
  const Detection d = detect(frame, formats, DetectionParams{});
  const double seconds = static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
  if (seconds > 20.0) fail("detect() took " + std::to_string(seconds) + " s of processor time");

  switch (d.status) {
    case DetectionStatus::kOk:
    case DetectionStatus::kNoPlane:
    case DetectionStatus::kNoLayer:
    case DetectionStatus::kNoLayout:
    case DetectionStatus::kBadFrame:
    case DetectionStatus::kEmpty:
    case DetectionStatus::kSlipSheet:
    case DetectionStatus::kRecipeMismatch:
      break;
    default:
      fail("detect() returned no valid status");
  }
  if (d.status != DetectionStatus::kOk && d.message.empty()) fail(std::string("status ") + to_string(d.status) + " without a message");
  if (d.status != DetectionStatus::kOk && !d.boxes.empty())
    fail(std::string("status ") + to_string(d.status) + " with boxes");
  if (d.status == DetectionStatus::kOk) {
    if (d.boxes.empty()) fail("status ok without boxes");
    for (const DetectedBox& b : d.boxes) {
      if (!b.center.allFinite() || !b.long_axis.allFinite() || !b.normal.allFinite() ||
          !std::isfinite(b.long_m) || !std::isfinite(b.short_m))
        fail("status ok with a non-finite box");
      if (b.format < 0 || static_cast<std::size_t>(b.format) >= formats.size()) fail("box format index out of range");
    }
  }
  return 0;
}
