// The `web:` section (web_config_table.hpp).
#include "palletd/web/web_config_table.hpp"

namespace palletd {

using namespace config_table;

const Table<WebConfig>& web_table() {
  const auto address = [](const std::string& a) { return check_address(a, false); };
  static const Table<WebConfig> t = {
      flag("enabled", &WebConfig::enabled),
      within(&WebConfig::server,
             Field<WebOptions>{"bind_address",
                               [address](const Context& ctx, const YAML::Node& node, const std::string& path,
                                         WebOptions& out) {
                                 std::string v = read_string(ctx, node, path);
                                 if (auto e = address(v); !e.empty()) fail(ctx, node, path, e);
                                 out.bind_address = std::move(v);
                               },
                               compare_member(&WebOptions::bind_address), list_leaf<WebOptions>}),
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
      within(&MetricsConfig::server,
             Field<WebOptions>{"bind_address",
                               [](const Context& ctx, const YAML::Node& node, const std::string& path, WebOptions& out) {
                                 std::string v = read_string(ctx, node, path);
                                 if (auto e = check_address(v, false); !e.empty()) fail(ctx, node, path, e);
                                 out.bind_address = std::move(v);
                               },
                               compare_member(&WebOptions::bind_address), list_leaf<WebOptions>}),
      within(&MetricsConfig::server, integer("port", &WebOptions::port, 1, 65535)),
      within(&MetricsConfig::server, texts("allowed_hosts", &WebOptions::allowed_hosts)),
  };
  return t;
}

}  // namespace palletd
