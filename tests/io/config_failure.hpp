// What a configuration error says: line, column, key path and message (tests of the config's
// errors).
#pragma once

#include <string>

#include <catch2/catch.hpp>

#include "palletd/config/config.hpp"

namespace palletd::test {

struct ConfigFailure {
  int line = -1;
  int column = -1;
  std::string key;
  std::string what;
};

/// The ConfigError that parsing `text` throws; a test failure when it parses.
inline ConfigFailure config_failure_of(const std::string& text) {
  try {
    (void)parse_config(text, "bad.yaml");
  } catch (const ConfigError& e) {
    return {e.line(), e.column(), e.key_path(), e.what()};
  }
  FAIL("no ConfigError for:\n" << text);
  return {};
}

}  // namespace palletd::test
