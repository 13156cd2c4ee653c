// palletd web: how the `web:` section of the configuration binds to WebConfig. Read by
// palletd_config, which links palletd_config_table.
#pragma once

#include "palletd/config_table/table.hpp"
#include "palletd/web/web.hpp"

namespace palletd {

/// The `web:` section: whether the status page runs and its server's options.
const config_table::Table<WebConfig>& web_table();
/// The `metrics:` section: enabled, bind_address, port, allowed_hosts.
const config_table::Table<MetricsConfig>& metrics_table();

}  // namespace palletd
