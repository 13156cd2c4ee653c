// Helpers shared by the fuzz targets: a byte reader over the fuzzer's input and a private
// scratch folder (tmpfs when there is one) for targets that must go through files.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace palletd::fuzz {

/// Reads fields front to back; past the end every read gives 0 / an empty string.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  [[nodiscard]] std::size_t remaining() const { return size_ - at_; }
  std::uint8_t u8() { return at_ < size_ ? data_[at_++] : 0; }
  std::uint16_t u16() {
    const auto hi = static_cast<unsigned>(u8());
    return static_cast<std::uint16_t>((hi << 8) | u8());
  }
  std::uint32_t u32() {
    const std::uint32_t hi = u16();
    return (hi << 16) | u16();
  }
  /// Up to `n` bytes (fewer at the end of the input).
  std::string bytes(std::size_t n) {
    if (n > remaining()) n = remaining();
    std::string out(reinterpret_cast<const char*>(data_ + at_), n);
    at_ += n;
    return out;
  }
  std::string rest() { return bytes(remaining()); }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

/// A folder of this process's own, removed by nobody (one per fuzzer process, a few files).
const std::string& scratch_dir();

/// Writes `bytes` to `path`; aborts on failure (an environment problem, not a finding).
void write_file(const std::string& path, const std::string& bytes);

/// Prints the message and aborts: the fuzzer records the input as a crash.
[[noreturn]] inline void fail(const std::string& message) {
  std::fprintf(stderr, "fuzz oracle: %s\n", message.c_str());
  std::abort();
}

}  // namespace palletd::fuzz
