// palletd daemon: where main hands a validated configuration to the service.
#pragma once

#include "palletd/config/config.hpp"
#include "daemon.hpp"

namespace palletd {

/// Runs the service with a configuration that load_config accepted; returns the exit code.
int start_service(const DaemonOptions& options, Config config);

}  // namespace palletd
