// A fake StatusSource for the web tests and the browser-test server: a real detection of a frame
// (a bundled frame when given, else a synthetic 3x3 layer of 315x232 boxes rendered in memory),
// with a matching register image as the service would publish it.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "palletd/detection/detection.hpp"
#include "palletd/service/service.hpp"
#include "palletd/web/web.hpp"

namespace palletd::testing {

class WebFixture {
 public:
  /// `frame_stem` empty: the synthetic layer. Throws std::runtime_error when the frame cannot be read.
  explicit WebFixture(const std::string& frame_stem = "");

  /// The source the server reads; its callbacks point into this fixture (keep it alive).
  [[nodiscard]] StatusSource source();

  void set_latest(std::shared_ptr<const ResultSnapshot> snapshot);
  [[nodiscard]] std::shared_ptr<const ResultSnapshot> latest() const;
  void set_registers(const modbus::RegisterImage& image);
  /// The register image for a result the way the service encodes it (status and result blocks).
  [[nodiscard]] modbus::RegisterImage encode(const ResultSnapshot& snapshot, std::uint16_t status_word) const;

  [[nodiscard]] const ResultSnapshot& first() const { return *first_; }
  [[nodiscard]] const std::vector<RecipeInfo>& recipes() const { return recipes_; }
  ServiceHealth health;
  std::atomic<int> snapshot_requests{0};

 private:
  std::shared_ptr<const ResultSnapshot> first_;
  std::vector<RecipeInfo> recipes_;
  mutable std::mutex mutex_;
  std::shared_ptr<const ResultSnapshot> latest_;
  modbus::RegisterImage image_{};
};

}  // namespace palletd::testing
