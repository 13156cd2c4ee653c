// Fuzz target: the frame reader (shared/spec/frames.md): STEM.json, STEM.depth.png and the
// optional STEM.intensity.png, through read_frame() as the replay driver and palletctl use it.
//
// Input: u16 n, n bytes of JSON; u32 m, m bytes of depth PNG; the rest (if any) is the intensity
// PNG. Oracle: read_frame() either fails with a message or returns a consistent frame, which
// write_frame() accepts and which reads back with the same pixels.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "fuzz_util.hpp"
#include "palletd/frames/frame_io.hpp"

using namespace palletd;
using fuzz::fail;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::ByteReader in(data, size);
  const std::string json = in.bytes(in.u16());
  const std::string depth = in.bytes(in.u32());
  const std::string intensity = in.rest();

  const std::string stem = fuzz::scratch_dir() + "/in";
  fuzz::write_file(stem + ".json", json);
  fuzz::write_file(stem + ".depth.png", depth);
  if (intensity.empty()) std::remove((stem + ".intensity.png").c_str());
  else fuzz::write_file(stem + ".intensity.png", intensity);

  const Expected<Frame> frame = read_frame(stem);
  if (!frame) {
    if (frame.error().empty()) fail("read_frame failed without a message");
    return 0;
  }
  const Frame& f = *frame;
  if (!f.intrinsics.valid()) fail("accepted invalid intrinsics");
  if (!(f.depth_scale_m > 0.0) || !std::isfinite(f.depth_scale_m)) fail("accepted a bad depth_scale");
  if (f.depth.size() != f.pixel_count()) fail("depth size does not match the intrinsics");
  if (f.has_intensity() && f.intensity.size() != f.pixel_count()) fail("intensity size mismatch");
  if (f.has_intensity() != (f.intensity_bits == 8 || f.intensity_bits == 16)) fail("intensity_bits");

  const std::string copy = fuzz::scratch_dir() + "/copy";
  if (const Status s = write_frame(copy, f); !s) fail("write_frame refused a frame read_frame gave: " + s.error());
  const Expected<Frame> again = read_frame(copy);
  if (!again) fail("a written frame does not read back: " + again.error());
  if (again->depth != f.depth || again->intensity != f.intensity ||
      again->intensity_bits != f.intensity_bits || again->intrinsics.width != f.intrinsics.width ||
      again->intrinsics.height != f.intrinsics.height)
    fail("a frame changed on its way through write_frame/read_frame");
  if (!f.has_intensity()) std::remove((copy + ".intensity.png").c_str());
  return 0;
}
