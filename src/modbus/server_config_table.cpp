// The `modbus:` section (server_config_table.hpp).
#include "palletd/modbus/server_config_table.hpp"

namespace palletd::modbus {

using namespace config_table;

namespace {

/// A yes/no key that selects the 32-bit word order: yes = low word first.
template <typename S>
Field<S> word_order_flag(const char* key, WordOrder S::*member) {
  return {key,
          [member](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            out.*member = read_bool(ctx, node, path) ? WordOrder::kLowWordFirst : WordOrder::kHighWordFirst;
          },
          compare_member(member), list_leaf<S>};
}

}  // namespace

const Table<ServerOptions>& server_table() {
  using M = ServerOptions;
  const auto address = [](const std::string& a) { return check_address(a, false); };
  const auto block = [](const std::string& a) { return check_address(a, true); };
  static const Table<M> t = {
      {"bind_address",
       [address](const Context& ctx, const YAML::Node& node, const std::string& path, M& out) {
         std::string v = read_string(ctx, node, path);
         if (auto e = address(v); !e.empty()) fail(ctx, node, path, e);
         out.bind_address = std::move(v);
       },
       compare_member(&M::bind_address), list_leaf<M>},
      integer("port", &M::port, 1, 65535),
      integer("unit_id", &M::unit_id, 0, 255),
      within(&M::handshake, word_order_flag("low_word_first", &HandshakeOptions::word_order)),
      texts("allow", &M::allow, block),
      texts("read_only", &M::read_only, block),
      integer("max_connections", &M::max_connections, 1, 1024),
      number("idle_timeout_s", &M::idle_timeout_s, Range::closed(0.0, 86400.0)),
      within(&M::handshake, number("plc_heartbeat_timeout_s", &HandshakeOptions::plc_heartbeat_timeout_s,
                                   Range::closed(0.0, 3600.0))),
  };
  return t;
}

}  // namespace palletd::modbus
