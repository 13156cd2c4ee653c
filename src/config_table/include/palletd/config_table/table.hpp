// palletd config_table: table-driven binding of YAML mappings to plain structs, shared by
// palletd_config and by the modules that bind their own options (the drivers, the Modbus server,
// the status page).
//
// A section is a table of fields; binding another struct member is one line:
//   number("max_tilt_deg", &PlaneParams::max_tilt_deg, Range::closed(0.0, 90.0)),
// The same table reads the YAML, compares two structs (config_differences) and lists the
// documented key paths (config_key_paths). Every error is a ConfigError with its place.
#pragma once

#include <algorithm>
#include <functional>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace palletd {

/// A configuration error with its place: "FILE:LINE:COLUMN: KEY.PATH: message".
class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, int line, int column, std::string key_path, const std::string& message);
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] int line() const { return line_; }      ///< 1-based, 0 when unknown
  [[nodiscard]] int column() const { return column_; }  ///< 1-based, 0 when unknown
  [[nodiscard]] const std::string& key_path() const { return key_path_; }

 private:
  std::string file_;
  int line_;
  int column_;
  std::string key_path_;
};

namespace config_table {

/// Where we are: the file name for messages and the folder relative paths are resolved against.
struct Context {
  std::string file;
  std::string base_directory;  ///< empty = leave relative paths as written
};

[[noreturn]] void fail(const Context& ctx, const YAML::Node& at, const std::string& path, const std::string& message);
[[noreturn]] void fail_at(const Context& ctx, const YAML::Mark& mark, const std::string& path,
                          const std::string& message);
std::string join(const std::string& path, const std::string& key);
/// "a string", "a list", "a mapping", "nothing": what the node is, for messages.
std::string describe(const YAML::Node& node);

double read_double(const Context& ctx, const YAML::Node& node, const std::string& path);
long long read_integer(const Context& ctx, const YAML::Node& node, const std::string& path);
bool read_bool(const Context& ctx, const YAML::Node& node, const std::string& path);
std::string read_string(const Context& ctx, const YAML::Node& node, const std::string& path);
std::vector<std::string> read_strings(const Context& ctx, const YAML::Node& node, const std::string& path);
/// Makes a relative path absolute against ctx.base_directory (when set).
std::string resolve_path(const Context& ctx, const std::string& path);
/// The mapping's keys, each checked against `allowed`; duplicates and unknown keys are errors.
void check_keys(const Context& ctx, const YAML::Node& map, const std::string& path,
                const std::vector<std::string>& allowed);

/// A closed or half-open range for numbers.
struct Range {
  double lo;
  double hi;
  bool lo_open = false;
  static Range closed(double lo, double hi) { return {lo, hi, false}; }
  static Range positive(double hi) { return {0.0, hi, true}; }
  [[nodiscard]] bool contains(double v) const { return (lo_open ? v > lo : v >= lo) && v <= hi; }
  [[nodiscard]] std::string text() const {
    std::ostringstream s;
    if (lo_open) {
      s << "> " << lo << " and <= " << hi;
    } else {
      s << "between " << lo << " and " << hi;
    }
    return s.str();
  }
};

template <typename S>
struct Field {
  std::string key;
  std::function<void(const Context&, const YAML::Node&, const std::string&, S&)> read;
  std::function<void(const S&, const S&, const std::string&, std::vector<std::string>&)> compare;
  std::function<void(const std::string&, std::vector<std::string>&)> list;
};

template <typename S>
using Table = std::vector<Field<S>>;

template <typename S>
void list_leaf(const std::string& path, std::vector<std::string>& keys) {
  keys.push_back(path);
}

template <typename S, typename T>
std::function<void(const S&, const S&, const std::string&, std::vector<std::string>&)> compare_member(T S::*member) {
  return [member](const S& a, const S& b, const std::string& path, std::vector<std::string>& diffs) {
    if (!(a.*member == b.*member)) diffs.push_back(path);
  };
}

/// A floating-point member with its valid range.
template <typename S, typename T>
Field<S> number(const char* key, T S::*member, Range range) {
  return {key,
          [member, range](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            const double v = read_double(ctx, node, path);
            if (!range.contains(v)) fail(ctx, node, path, "must be " + range.text());
            out.*member = static_cast<T>(v);
          },
          compare_member(member), list_leaf<S>};
}

/// An optional floating-point member: null (or ~) leaves it unset, a number must lie in range.
template <typename S>
Field<S> optional_number(const char* key, std::optional<double> S::*member, Range range) {
  return {key,
          [member, range](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            if (node.IsNull()) {
              out.*member = std::nullopt;
              return;
            }
            const double v = read_double(ctx, node, path);
            if (!range.contains(v)) fail(ctx, node, path, "must be " + range.text() + " (or null: unknown)");
            out.*member = v;
          },
          compare_member(member), list_leaf<S>};
}

/// An integer member with its valid range (inclusive).
template <typename S, typename T>
Field<S> integer(const char* key, T S::*member, long long lo, long long hi) {
  return {key,
          [member, lo, hi](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            const long long v = read_integer(ctx, node, path);
            if (v < lo || v > hi)
              fail(ctx, node, path, "must be between " + std::to_string(lo) + " and " + std::to_string(hi));
            out.*member = static_cast<T>(v);
          },
          compare_member(member), list_leaf<S>};
}

template <typename S>
Field<S> flag(const char* key, bool S::*member) {
  return {key,
          [member](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            out.*member = read_bool(ctx, node, path);
          },
          compare_member(member), list_leaf<S>};
}

/// A string member; `allowed` (when not empty) lists the accepted values.
template <typename S>
Field<S> text(const char* key, std::string S::*member, std::vector<std::string> allowed = {}) {
  return {key,
          [member, allowed = std::move(allowed)](const Context& ctx, const YAML::Node& node,
                                                 const std::string& path, S& out) {
            std::string v = read_string(ctx, node, path);
            if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), v) == allowed.end()) {
              std::string list;
              for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
              fail(ctx, node, path, "must be one of " + list + " (not '" + v + "')");
            }
            out.*member = std::move(v);
          },
          compare_member(member), list_leaf<S>};
}

/// A filesystem path, resolved against the config file's folder when relative.
template <typename S>
Field<S> file_path(const char* key, std::string S::*member) {
  return {key,
          [member](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            out.*member = resolve_path(ctx, read_string(ctx, node, path));
          },
          compare_member(member), list_leaf<S>};
}

/// An enum member written as one of the given words.
template <typename S, typename E>
Field<S> choice(const char* key, E S::*member, std::vector<std::pair<std::string, E>> words) {
  return {key,
          [member, words](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            const std::string v = read_string(ctx, node, path);
            std::string list;
            for (const auto& [word, value] : words) {
              if (word == v) {
                out.*member = value;
                return;
              }
              list += (list.empty() ? "" : ", ") + word;
            }
            fail(ctx, node, path, "must be one of " + list + " (not '" + v + "')");
          },
          compare_member(member), list_leaf<S>};
}

/// A list of strings; `check` (optional) validates each entry and returns an error or "".
template <typename S>
Field<S> texts(const char* key, std::vector<std::string> S::*member,
               std::function<std::string(const std::string&)> check = {}) {
  return {key,
          [member, check = std::move(check)](const Context& ctx, const YAML::Node& node,
                                             const std::string& path, S& out) {
            std::vector<std::string> v = read_strings(ctx, node, path);
            if (check) {
              for (std::size_t i = 0; i < v.size(); ++i) {
                if (auto e = check(v[i]); !e.empty())
                  fail(ctx, node[i], path + "[" + std::to_string(i) + "]", e);
              }
            }
            out.*member = std::move(v);
          },
          compare_member(member), list_leaf<S>};
}

template <typename S>
void read_section(const Context& ctx, const YAML::Node& node, const std::string& path, const Table<S>& table,
                  S& out) {
  if (node.IsNull()) return;  // "section:" with nothing under it keeps the defaults
  if (!node.IsMap()) fail(ctx, node, path, "expected a mapping of keys, got " + describe(node));
  std::vector<std::string> allowed;
  allowed.reserve(table.size());
  for (const auto& f : table) allowed.push_back(f.key);
  check_keys(ctx, node, path, allowed);
  for (const auto& f : table) {
    const YAML::Node value = node[f.key];
    if (value) f.read(ctx, value, join(path, f.key), out);
  }
}

template <typename S>
void compare_section(const S& a, const S& b, const std::string& path, const Table<S>& table,
                     std::vector<std::string>& diffs) {
  for (const auto& f : table) f.compare(a, b, join(path, f.key), diffs);
}

template <typename S>
void list_section(const std::string& path, const Table<S>& table, std::vector<std::string>& keys) {
  for (const auto& f : table) f.list(join(path, f.key), keys);
}

/// A nested section bound to a member struct with its own table.
template <typename S, typename Sub>
Field<S> section(const char* key, Sub S::*member, const Table<Sub>& (*table)()) {
  return {key,
          [member, table](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            read_section(ctx, node, path, table(), out.*member);
          },
          [member, table](const S& a, const S& b, const std::string& path, std::vector<std::string>& diffs) {
            compare_section(a.*member, b.*member, path, table(), diffs);
          },
          [table](const std::string& path, std::vector<std::string>& keys) { list_section(path, table(), keys); }};
}

/// A field of a member struct bound at this level: the key stays flat in the file while the
/// value lives in `member` (one section of the file for a struct split by purpose).
template <typename S, typename Sub>
Field<S> within(Sub S::*member, Field<Sub> field) {
  return {field.key,
          [member, read = field.read](const Context& ctx, const YAML::Node& node, const std::string& path, S& out) {
            read(ctx, node, path, out.*member);
          },
          [member, compare = field.compare](const S& a, const S& b, const std::string& path,
                                            std::vector<std::string>& diffs) { compare(a.*member, b.*member, path, diffs); },
          field.list};
}

/// The value of a key the mapping must have (a ConfigError naming it otherwise).
YAML::Node require(const Context& ctx, const YAML::Node& map, const std::string& path, const char* key);
/// "path[i]".
std::string index_path(const std::string& path, std::size_t i);
/// "" when the text is an IPv4/IPv6 address or CIDR block (allow_prefix), else the problem.
std::string check_address(const std::string& text, bool allow_prefix);

}  // namespace config_table
}  // namespace palletd
