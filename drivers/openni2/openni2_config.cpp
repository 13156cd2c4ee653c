// The OpenNI2 driver's options as the configuration binds them (driver_config_tables.hpp).
#include "driver_config_tables.hpp"

namespace palletd {

using namespace config_table;

const Table<OpenNI2Options>& openni2_table() {
  static const Table<OpenNI2Options> t = {
      text("uri", &OpenNI2Options::uri),
      integer("width", &OpenNI2Options::width, 1, 10000),
      integer("height", &OpenNI2Options::height, 1, 10000),
      integer("fps", &OpenNI2Options::fps, 1, 1000),
      number("depth_unit_m", &OpenNI2Options::depth_unit_m, Range::positive(1.0)),
      flag("ir_as_intensity", &OpenNI2Options::ir_as_intensity),
      flag("loop", &OpenNI2Options::loop),
  };
  return t;
}

}  // namespace palletd
