// The `camera:` section (camera_config_table.hpp).
#include "palletd/drivers/camera_config_table.hpp"

#include <array>

#include "driver_config_tables.hpp"

namespace palletd {

using namespace config_table;

namespace {

std::optional<Intrinsics> read_intrinsics(const Context& ctx, const YAML::Node& node,
                                          const std::string& path) {
  if (node.IsNull()) return std::nullopt;
  if (!node.IsMap())
    fail(ctx, node, path, "expected a mapping (width, height, fx, fy, cx, cy, distortion) or null");
  check_keys(ctx, node, path, {"width", "height", "fx", "fy", "cx", "cy", "distortion"});
  Intrinsics k;
  for (auto [key, out] : {std::pair<const char*, int*>{"width", &k.width}, {"height", &k.height}}) {
    const YAML::Node v = require(ctx, node, path, key);
    const long long n = read_integer(ctx, v, join(path, key));
    if (n < 1 || n > 10000) fail(ctx, v, join(path, key), "must be between 1 and 10000");
    *out = static_cast<int>(n);
  }
  for (auto [key, out] : {std::pair<const char*, double*>{"fx", &k.fx}, {"fy", &k.fy}}) {
    const YAML::Node v = require(ctx, node, path, key);
    *out = read_double(ctx, v, join(path, key));
    if (*out <= 0.0) fail(ctx, v, join(path, key), "focal length must be > 0");
  }
  for (auto [key, out] : {std::pair<const char*, double*>{"cx", &k.cx}, {"cy", &k.cy}})
    *out = read_double(ctx, require(ctx, node, path, key), join(path, key));
  if (const YAML::Node d = node["distortion"]; d && !d.IsNull()) {
    const std::string dpath = join(path, "distortion");
    if (!d.IsSequence() || d.size() != 5)
      fail(ctx, d, dpath, "expected a list of 5 numbers (k1 k2 p1 p2 k3), got " + describe(d));
    std::array<double, 5> coeffs{};
    for (std::size_t i = 0; i < 5; ++i) coeffs[i] = read_double(ctx, d[i], index_path(dpath, i));
    k.distortion = coeffs;
  }
  return k;
}

Field<CameraConfig> intrinsics_field() {
  return {"intrinsics",
          [](const Context& ctx, const YAML::Node& node, const std::string& path, CameraConfig& out) {
            out.intrinsics_override = read_intrinsics(ctx, node, path);
          },
          [](const CameraConfig& a, const CameraConfig& b, const std::string& path,
             std::vector<std::string>& diffs) {
            const auto& x = a.intrinsics_override;
            const auto& y = b.intrinsics_override;
            const bool same =
                x.has_value() == y.has_value() &&
                (!x || (x->width == y->width && x->height == y->height && x->fx == y->fx && x->fy == y->fy &&
                        x->cx == y->cx && x->cy == y->cy && x->distortion == y->distortion));
            if (!same) diffs.push_back(path);
          },
          list_leaf<CameraConfig>};
}

}  // namespace

const Table<CameraConfig>& camera_table() {
  static const Table<CameraConfig> t = {
      text("driver", &CameraConfig::driver, {"replay", "aravis", "openni2"}),
      number("frame_timeout_ms", &CameraConfig::frame_timeout_ms, Range::positive(600000.0)),
      number("reconnect_min_s", &CameraConfig::reconnect_min_s, Range::positive(3600.0)),
      number("reconnect_max_s", &CameraConfig::reconnect_max_s, Range::positive(3600.0)),
      number("control_timeout_ms", &CameraConfig::control_timeout_ms, Range::positive(60000.0)),
      intrinsics_field(),
      section("replay", &CameraConfig::replay, replay_table),
      section("aravis", &CameraConfig::aravis, aravis_table),
      section("openni2", &CameraConfig::openni2, openni2_table),
  };
  return t;
}

}  // namespace palletd
