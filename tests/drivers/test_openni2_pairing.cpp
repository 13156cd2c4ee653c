// The OpenNI2 driver's depth/IR pairing rules (drivers/openni2/frame_pairing.hpp) alone: the
// newest depth frame, its IR frame by device timestamp, bounded waits. No OpenNI runtime needed.
#include <catch2/catch.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>
#include <utility>

#include "openni2/frame_pairing.hpp"

using namespace palletd;
using std::chrono::milliseconds;

namespace {

using Pairing = openni2::FramePairing<int>;

Pairing::Entry entry(std::uint64_t timestamp_us, int index) {
  return Pairing::Entry{timestamp_us, index, std::make_shared<const int>(index)};
}

}  // namespace

TEST_CASE("openni2 pairing: newest depth frame, its IR by timestamp, bounded waits") {
  using std::chrono::steady_clock;
  constexpr std::uint64_t kPeriod = 33333, kHalf = kPeriod / 2;
  Pairing p(4);

  SECTION("a slow consumer: the newest depth frame and its own IR out of several") {
    for (int n = 0; n < 3; ++n) {
      p.push(Pairing::Stream::kDepth, entry(n * kPeriod, n + 1));
      p.push(Pairing::Stream::kIr, entry(n * kPeriod + 40, n + 1));  // IR a little later
    }
    auto d = p.take_depth(steady_clock::now());
    REQUIRE(d);
    CHECK(d->index == 3);
    CHECK(p.sizes().first == 0u);  // older depth frames are skipped
    const auto t0 = steady_clock::now();
    auto ir = p.take_ir_partner(d->timestamp_us, kHalf, t0 + milliseconds(500));
    REQUIRE(ir);
    CHECK(*ir->frame == 3);
    CHECK(steady_clock::now() - t0 < milliseconds(400));  // there already: no wait
    CHECK(p.sizes().second == 0u);  // the older IR frames can pair with nothing later
  }
  SECTION("the nearest IR frame within half a period") {
    p.push(Pairing::Stream::kIr, entry(1000 * kPeriod - 15000, 1));
    p.push(Pairing::Stream::kIr, entry(1000 * kPeriod + 2000, 2));
    p.push(Pairing::Stream::kIr, entry(1000 * kPeriod + 16000, 3));
    auto ir = p.take_ir_partner(1000 * kPeriod, kHalf, steady_clock::now());
    REQUIRE(ir);
    CHECK(*ir->frame == 2);
    CHECK(p.sizes().second == 1u);  // the later one stays for the next depth frame
  }
  SECTION("an IR frame still on its way is waited for") {
    std::thread late([&] {
      std::this_thread::sleep_for(milliseconds(50));
      p.push(Pairing::Stream::kIr, entry(5 * kPeriod - 100, 6));
    });
    auto ir = p.take_ir_partner(5 * kPeriod, kHalf, steady_clock::now() + milliseconds(5000));
    late.join();
    REQUIRE(ir);
    CHECK(*ir->frame == 6);
  }
  SECTION("IR already past the depth frame's instant: none, without waiting") {
    p.push(Pairing::Stream::kIr, entry(7 * kPeriod, 8));
    const auto t0 = steady_clock::now();
    CHECK_FALSE(p.take_ir_partner(6 * kPeriod, kHalf, t0 + milliseconds(2000)));
    CHECK(steady_clock::now() - t0 < milliseconds(1000));
    CHECK(p.sizes().second == 1u);
  }
  SECTION("no IR at all: none once the deadline passes; no depth frame: none either") {
    const auto t0 = steady_clock::now();
    CHECK_FALSE(p.take_ir_partner(kPeriod, kHalf, t0 + milliseconds(60)));
    CHECK(steady_clock::now() - t0 >= milliseconds(60));
    CHECK_FALSE(p.take_depth(steady_clock::now() + milliseconds(20)));
  }
  SECTION("each ring keeps its newest frames up to its capacity; clear() empties both") {
    for (int n = 0; n < 7; ++n) {
      p.push(Pairing::Stream::kDepth, entry(n * kPeriod, n + 1));
      p.push(Pairing::Stream::kIr, entry(n * kPeriod, n + 1));
    }
    CHECK(p.sizes() == std::make_pair(std::size_t{4}, std::size_t{4}));
    auto ir = p.take_ir_partner(2 * kPeriod, kHalf, steady_clock::now());
    CHECK_FALSE(ir);  // IR of frame 3 fell out of the ring; the IR stream is past it
    p.clear();
    CHECK(p.sizes() == std::make_pair(std::size_t{0}, std::size_t{0}));
  }
}
