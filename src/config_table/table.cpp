// The binding machinery of config_table/table.hpp: errors with their place, typed reads, key checks.
#include "palletd/config_table/table.hpp"

#include <cmath>
#include <filesystem>
#include <set>

#include <arpa/inet.h>

namespace palletd {

namespace {

std::string error_text(const std::string& file, int line, int column, const std::string& key_path,
                       const std::string& message) {
  std::string text = file;
  if (line > 0) text += ":" + std::to_string(line) + ":" + std::to_string(column);
  text += ": ";
  if (!key_path.empty()) text += key_path + ": ";
  return text + message;
}

}  // namespace

ConfigError::ConfigError(std::string file, int line, int column, std::string key_path,
                         const std::string& message)
    : std::runtime_error(error_text(file, line, column, key_path, message)),
      file_(std::move(file)),
      line_(line),
      column_(column),
      key_path_(std::move(key_path)) {}

namespace config_table {

void fail_at(const Context& ctx, const YAML::Mark& mark, const std::string& path,
             const std::string& message) {
  if (mark.is_null()) throw ConfigError(ctx.file, 0, 0, path, message);
  throw ConfigError(ctx.file, mark.line + 1, mark.column + 1, path, message);
}

void fail(const Context& ctx, const YAML::Node& at, const std::string& path, const std::string& message) {
  fail_at(ctx, at.Mark(), path, message);
}

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

namespace {

bool quoted(const YAML::Node& node) { return node.Tag() == "!"; }

}  // namespace

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined:
      return "nothing";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Scalar:
      return (quoted(node) ? "the string '" : "'") + node.Scalar() + "'";
  }
  return "something else";
}

double read_double(const Context& ctx, const YAML::Node& node, const std::string& path) {
  double v = 0.0;
  if (!node.IsScalar() || quoted(node) || !YAML::convert<double>::decode(node, v))
    fail(ctx, node, path, "expected a number, got " + describe(node));
  if (!std::isfinite(v)) fail(ctx, node, path, "must be a finite number");
  return v;
}

long long read_integer(const Context& ctx, const YAML::Node& node, const std::string& path) {
  long long v = 0;
  if (!node.IsScalar() || quoted(node) || !YAML::convert<long long>::decode(node, v))
    fail(ctx, node, path, "expected an integer, got " + describe(node));
  return v;
}

bool read_bool(const Context& ctx, const YAML::Node& node, const std::string& path) {
  bool v = false;
  if (!node.IsScalar() || quoted(node) || !YAML::convert<bool>::decode(node, v))
    fail(ctx, node, path, "expected true or false, got " + describe(node));
  return v;
}

std::string read_string(const Context& ctx, const YAML::Node& node, const std::string& path) {
  if (!node.IsScalar()) fail(ctx, node, path, "expected a string, got " + describe(node));
  return node.Scalar();
}

std::vector<std::string> read_strings(const Context& ctx, const YAML::Node& node, const std::string& path) {
  std::vector<std::string> out;
  if (node.IsNull()) return out;
  if (!node.IsSequence()) fail(ctx, node, path, "expected a list of strings, got " + describe(node));
  for (std::size_t i = 0; i < node.size(); ++i)
    out.push_back(read_string(ctx, node[i], path + "[" + std::to_string(i) + "]"));
  return out;
}

std::string resolve_path(const Context& ctx, const std::string& path) {
  if (path.empty() || ctx.base_directory.empty()) return path;
  const std::filesystem::path p(path);
  if (p.is_absolute()) return path;
  return (std::filesystem::path(ctx.base_directory) / p).lexically_normal().string();
}

void check_keys(const Context& ctx, const YAML::Node& map, const std::string& path,
                const std::vector<std::string>& allowed) {
  std::set<std::string> seen;
  for (auto it = map.begin(); it != map.end(); ++it) {
    const YAML::Node key = it->first;
    if (!key.IsScalar()) fail(ctx, key, path, "keys must be plain words, got " + describe(key));
    const std::string& name = key.Scalar();
    if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
      std::string known;
      for (const auto& a : allowed) known += (known.empty() ? "" : ", ") + a;
      fail(ctx, key, join(path, name), "unknown key (known here: " + known + ")");
    }
    if (!seen.insert(name).second) fail(ctx, key, join(path, name), "duplicate key");
  }
}

// (Never assign one YAML::Node to another: yaml-cpp's assignment rewrites the referenced node.)
YAML::Node require(const Context& ctx, const YAML::Node& map, const std::string& path, const char* key) {
  YAML::Node value = map[key];
  if (!value) fail(ctx, map, path, std::string("missing key '") + key + "'");
  return value;
}

std::string index_path(const std::string& path, std::size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

std::string check_address(const std::string& text, bool allow_prefix) {
  std::string address = text;
  int prefix = -1;
  if (const auto slash = text.find('/'); slash != std::string::npos) {
    if (!allow_prefix) return "'" + text + "' must be a plain IP address (no /prefix)";
    address = text.substr(0, slash);
    const std::string digits = text.substr(slash + 1);
    if (digits.empty() || digits.size() > 3 || digits.find_first_not_of("0123456789") != std::string::npos)
      return "'" + text + "' has a bad prefix length";
    prefix = std::stoi(digits);
  }
  unsigned char buffer[16];
  if (inet_pton(AF_INET, address.c_str(), buffer) == 1) {
    if (prefix > 32) return "'" + text + "': an IPv4 prefix length is at most 32";
    return {};
  }
  if (inet_pton(AF_INET6, address.c_str(), buffer) == 1) {
    if (prefix > 128) return "'" + text + "': an IPv6 prefix length is at most 128";
    return {};
  }
  return "'" + text + "' is not an IP address" + std::string(allow_prefix ? " or CIDR block" : "");
}

}  // namespace config_table
}  // namespace palletd
