// The replay driver's options as the configuration binds them (driver_config_tables.hpp).
#include "driver_config_tables.hpp"

namespace palletd {

using namespace config_table;

const Table<ReplayOptions>& replay_table() {
  static const Table<ReplayOptions> t = {
      file_path("directory", &ReplayOptions::directory),
      flag("loop", &ReplayOptions::loop),
      number("rate_hz", &ReplayOptions::rate_hz, Range::closed(0.0, 1000.0)),
  };
  return t;
}

}  // namespace palletd
