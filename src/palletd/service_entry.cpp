#include "service_entry.hpp"

#include <spdlog/spdlog.h>

#include "daemon.hpp"

namespace palletd {

int start_service(const DaemonOptions& options, Config config) {
  spdlog::set_level(spdlog::level::from_str(config.logging.level));
  return run_daemon(options, std::move(config));
}

}  // namespace palletd
