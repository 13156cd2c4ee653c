// palletd modbus: how the `modbus:` section of the configuration binds to ServerOptions. Read by
// palletd_config, which links palletd_config_table.
#pragma once

#include "palletd/config_table/table.hpp"
#include "palletd/modbus/server.hpp"

namespace palletd::modbus {

/// The `modbus:` section: bind address, port, unit id, word order, address lists, limits.
const config_table::Table<ServerOptions>& server_table();

}  // namespace palletd::modbus
