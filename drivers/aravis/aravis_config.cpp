// The Aravis driver's options as the configuration binds them (driver_config_tables.hpp).
#include "driver_config_tables.hpp"

namespace palletd {

using namespace config_table;

const Table<AravisOptions>& aravis_table() {
  static const Table<AravisOptions> t = {
      text("address", &AravisOptions::address),
      text("serial", &AravisOptions::serial),
      text("user_id", &AravisOptions::user_id),
      text("pixel_format", &AravisOptions::pixel_format, {"Coord3D_C16", "Coord3D_ABC32f", "Mono16"}),
      number("mono16_scale_m", &AravisOptions::mono16_scale_m, Range::positive(1.0)),
      integer("packet_size", &AravisOptions::packet_size, 0, 65535),
      flag("packet_resend", &AravisOptions::packet_resend),
      integer("buffer_count", &AravisOptions::buffer_count, 1, 256),
      flag("software_trigger", &AravisOptions::software_trigger),
  };
  return t;
}

}  // namespace palletd
