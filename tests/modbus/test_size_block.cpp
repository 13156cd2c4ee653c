// The size block 910..974: each reported box's top face in 0.1 mm, the measured-size flag and
// format 0xFFFF of a size-range recipe, the result id copy that ends the register space.
#include <catch2/catch.hpp>

#include "palletd/modbus/register_map.hpp"

using namespace palletd::modbus;

TEST_CASE("box sizes go to 910 + 2 i in 0.1 mm, measured sizes set flag bit5 and format 0xFFFF",
          "[modbus][register_map]") {
  ResultRecord in;
  in.status = ResultStatus::kOk;
  in.boxes.resize(3);
  in.formats_measured = true;
  for (std::size_t i = 0; i < in.boxes.size(); ++i) {
    in.boxes[i].format = 0xFFFF;
    in.boxes[i].long_m = 0.4012 + 0.001 * static_cast<double>(i);
    in.boxes[i].short_m = 0.2987;
  }
  RegisterImage image{};
  image.fill(0xABCD);
  encode_result(in, 9, WordOrder::kHighWordFirst, image);
  CHECK((image[kRegResultFlags] & kResFormatsMeasured) != 0);
  CHECK(image[kBoxStart + 7] == 0xFFFF);
  CHECK(image[kSizeStart] == 4012);
  CHECK(image[kSizeStart + 1] == 2987);
  CHECK(image[kSizeStart + kSizeStride * 2] == 4032);
  for (std::uint16_t a = kSizeStart + kSizeStride * 3; a < kSizeIdCopy; ++a)
    CHECK(image[a] == 0);                                                             // unused slots
  for (std::uint16_t a = kPickIdCopy + 1; a < kSizeStart; ++a) CHECK(image[a] == 0);  // the gap 903..909
  CHECK(image[kSizeIdCopy] == 9);
  const DecodedResult out = decode_result(image, WordOrder::kHighWordFirst);
  CHECK(out.ids_agree());
  CHECK(out.record.formats_measured);
  REQUIRE(out.record.boxes.size() == 3);
  CHECK(out.record.boxes[1].long_m == Approx(0.4022).margin(1e-6));
  CHECK(out.record.boxes[1].short_m == Approx(0.2987).margin(1e-6));
  image[kSizeIdCopy] = 8;  // a torn read of the size block
  CHECK_FALSE(decode_result(image, WordOrder::kHighWordFirst).ids_agree());
}
