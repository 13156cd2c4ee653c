// Fuzz target: the configuration loader (YAML text -> Config, src/io/config*.cpp).
// Oracle: parse_config() either returns a configuration or throws ConfigError with a message;
// any other exception, crash or sanitizer report is a finding. An accepted text parses to the
// same configuration a second time (no hidden state) and holds the limits the loader promises.
#include <cmath>
#include <cstdint>
#include <string>

#include "fuzz_util.hpp"
#include "palletd/config/config.hpp"

using namespace palletd;
using fuzz::fail;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  Config config;
  try {
    config = parse_config(text, "fuzz.yaml", "/palletd-fuzz-base");
  } catch (const ConfigError& e) {
    if (std::string(e.what()).empty()) fail("ConfigError without a message");
    return 0;
  }
  if (!config_differences(config, config).empty()) fail("a configuration differs from itself");
  const Config again = parse_config(text, "fuzz.yaml", "/palletd-fuzz-base");
  if (!config_differences(config, again).empty()) fail("the same text parsed to two configurations");
  for (const BoxFormat& f : config.formats) {
    if (!(f.long_m > 0.0) || !(f.short_m > 0.0) || !std::isfinite(f.long_m) || !std::isfinite(f.short_m))
      fail("accepted a box format with a non-positive or non-finite size: " + f.name);
  }
  if (config.modbus.port == 0) fail("accepted Modbus port 0 (the server would take any free port)");
  return 0;
}
