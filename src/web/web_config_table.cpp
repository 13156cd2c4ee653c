// The `web:` section (web_config_table.hpp).
#include "palletd/web/web_config_table.hpp"

namespace palletd {

using namespace config_table;

namespace {

/// `bind_address`, checked by check_address; shared by the page's and the metrics server's sections.
Field<WebOptions> bind_address_field() {
  return Field<WebOptions>{"bind_address",
                           [](const Context& ctx, const YAML::Node& node, const std::string& path, WebOptions& out) {
                             std::string v = read_string(ctx, node, path);
                             if (auto e = check_address(v, false); !e.empty()) fail(ctx, node, path, e);
                             out.bind_address = std::move(v);
                           },
                           compare_member(&WebOptions::bind_address), list_leaf<WebOptions>};
}

}  // namespace

const Table<WebConfig>& web_table() {
  static const Table<WebConfig> t = {
      flag("enabled", &WebConfig::enabled),
      within(&WebConfig::server, bind_address_field()),
      within(&WebConfig::server, integer("port", &WebOptions::port, 1, 65535)),
      within(&WebConfig::server, flag("allow_snapshot_post", &WebOptions::allow_snapshot_post)),
      within(&WebConfig::server, integer("refresh_ms", &WebOptions::refresh_ms, 100, 60000)),
      within(&WebConfig::server, texts("allowed_hosts", &WebOptions::allowed_hosts)),
  };
  return t;
}

const Table<MetricsConfig>& metrics_table() {
  static const Table<MetricsConfig> t = {
      flag("enabled", &MetricsConfig::enabled),
      within(&MetricsConfig::server, bind_address_field()),
      within(&MetricsConfig::server, integer("port", &WebOptions::port, 1, 65535)),
      within(&MetricsConfig::server, texts("allowed_hosts", &WebOptions::allowed_hosts)),
  };
  return t;
}

}  // namespace palletd
