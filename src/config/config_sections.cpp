// Configuration sections with a shape of their own: intrinsics override, camera_to_base, box
// formats and recipes, network addresses.
#include <cmath>
#include <map>
#include <tuple>
#include <utility>

#include "config_yaml.hpp"

namespace palletd::config_detail {

std::optional<Eigen::Isometry3d> read_camera_to_base(const Context& ctx, const YAML::Node& node,
                                                     const std::string& path) {
  if (node.IsNull()) return std::nullopt;
  if (!node.IsSequence() || node.size() != 16)
    fail(ctx, node, path, "expected a list of 16 numbers (4x4 row-major) or null, got " + describe(node));
  Eigen::Matrix4d t;
  for (std::size_t i = 0; i < 16; ++i)
    t(static_cast<Eigen::Index>(i / 4), static_cast<Eigen::Index>(i % 4)) =
        read_double(ctx, node[i], index_path(path, i));
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  if (t(3, 0) != 0.0 || t(3, 1) != 0.0 || t(3, 2) != 0.0 || t(3, 3) != 1.0)
    fail(ctx, node, path, "is not a rigid transform: the last row must be 0 0 0 1");
  const double error = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (error > 1e-3 || r.determinant() < 0.0)
    fail(ctx, node, path, "is not a rigid transform: the rotation part must be orthonormal with determinant +1");
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.matrix() = t;
  return iso;
}

std::vector<BoxFormat> read_formats(const Context& ctx, const YAML::Node& node, const std::string& path) {
  std::vector<BoxFormat> formats;
  if (node.IsNull()) return formats;
  if (!node.IsSequence()) fail(ctx, node, path, "expected a list of {name, long_mm, short_mm}, got " + describe(node));
  std::map<std::string, std::size_t> seen;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node entry = node[i];
    const std::string epath = index_path(path, i);
    if (!entry.IsMap()) fail(ctx, entry, epath, "expected a mapping {name, long_mm, short_mm}, got " + describe(entry));
    check_keys(ctx, entry, epath, {"name", "long_mm", "short_mm", "height_mm"});
    BoxFormat f;
    const YAML::Node name_node = require(ctx, entry, epath, "name");
    f.name = read_string(ctx, name_node, join(epath, "name"));
    if (f.name.empty()) fail(ctx, name_node, join(epath, "name"), "must not be empty");
    if (const auto it = seen.find(f.name); it != seen.end())
      fail(ctx, name_node, join(epath, "name"), "format '" + f.name + "' is already defined by " + index_path(path, it->second));
    seen.emplace(f.name, i);
    const YAML::Node long_node = require(ctx, entry, epath, "long_mm");
    const double long_mm = read_double(ctx, long_node, join(epath, "long_mm"));
    if (long_mm <= 0.0 || long_mm > 5000.0) fail(ctx, long_node, join(epath, "long_mm"), "must be > 0 and <= 5000");
    const YAML::Node short_node = require(ctx, entry, epath, "short_mm");
    const double short_mm = read_double(ctx, short_node, join(epath, "short_mm"));
    if (short_mm <= 0.0) fail(ctx, short_node, join(epath, "short_mm"), "must be > 0");
    if (short_mm > long_mm) fail(ctx, short_node, join(epath, "short_mm"), "must not exceed long_mm (long side first)");
    f.long_m = long_mm / 1000.0;
    f.short_m = short_mm / 1000.0;
    if (const YAML::Node height_node = entry["height_mm"]; height_node && !height_node.IsNull()) {
      const double height_mm = read_double(ctx, height_node, join(epath, "height_mm"));
      if (height_mm <= 0.0 || height_mm > 5000.0)
        fail(ctx, height_node, join(epath, "height_mm"), "must be > 0 and <= 5000 (or left out: unknown)");
      f.height_m = height_mm / 1000.0;
    }
    formats.push_back(std::move(f));
  }
  return formats;
}

namespace {

/// One side's [min, max] of a size range, millimetres in, metres out.
std::pair<double, double> read_side_range(const Context& ctx, const YAML::Node& node, const std::string& path) {
  if (!node.IsSequence() || node.size() != 2)
    fail(ctx, node, path, "expected [min, max] in millimetres, got " + describe(node));
  const double lo = read_double(ctx, node[0], index_path(path, 0));
  const double hi = read_double(ctx, node[1], index_path(path, 1));
  if (!(lo > 0.0 && lo <= hi && hi <= 5000.0)) fail(ctx, node, path, "must be 0 < min <= max <= 5000");
  return {lo / 1000.0, hi / 1000.0};
}

/// size_range_mm: {long: [min, max], short: [min, max]}: cartons nobody entered.
SizeRange read_size_range(const Context& ctx, const YAML::Node& node, const std::string& path) {
  if (!node.IsMap()) fail(ctx, node, path, "expected {long: [min, max], short: [min, max]}, got " + describe(node));
  check_keys(ctx, node, path, {"long", "short"});
  SizeRange range;
  std::tie(range.long_min_m, range.long_max_m) = read_side_range(ctx, require(ctx, node, path, "long"), join(path, "long"));
  std::tie(range.short_min_m, range.short_max_m) =
      read_side_range(ctx, require(ctx, node, path, "short"), join(path, "short"));
  if (range.short_min_m > range.long_max_m)
    fail(ctx, node, join(path, "short"), "the short side's minimum exceeds the long side's maximum");
  return range;
}

}  // namespace

std::vector<Recipe> read_recipes(const Context& ctx, const YAML::Node& node, const std::string& path,
                                 const std::vector<BoxFormat>& formats) {
  std::vector<Recipe> recipes;
  if (node.IsNull()) return recipes;
  if (!node.IsSequence()) fail(ctx, node, path, "expected a list of {number, name, formats}, got " + describe(node));
  std::map<int, std::size_t> seen;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node entry = node[i];
    const std::string epath = index_path(path, i);
    if (!entry.IsMap()) fail(ctx, entry, epath, "expected a mapping {number, name, formats}, got " + describe(entry));
    check_keys(ctx, entry, epath, {"number", "name", "formats", "size_range_mm"});
    Recipe r;
    const YAML::Node v = require(ctx, entry, epath, "number");
    const long long number = read_integer(ctx, v, join(epath, "number"));
    if (number < 1 || number > 65535) fail(ctx, v, join(epath, "number"), "must be between 1 and 65535");
    r.number = static_cast<int>(number);
    if (const auto it = seen.find(r.number); it != seen.end())
      fail(ctx, v, join(epath, "number"),
           "recipe number " + std::to_string(r.number) + " is already used by " + index_path(path, it->second));
    seen.emplace(r.number, i);
    if (const YAML::Node name = entry["name"]) r.name = read_string(ctx, name, join(epath, "name"));
    if (const YAML::Node range = entry["size_range_mm"]) {
      if (entry["formats"]) fail(ctx, range, join(epath, "size_range_mm"), "a recipe has formats or a size range, not both");
      r.size_range = read_size_range(ctx, range, join(epath, "size_range_mm"));
      recipes.push_back(std::move(r));
      continue;
    }
    const std::string fpath = join(epath, "formats");
    const YAML::Node names = require(ctx, entry, epath, "formats");
    const std::vector<std::string> list = read_strings(ctx, names, fpath);
    if (list.empty()) fail(ctx, names, fpath, "a recipe needs at least one format");
    for (std::size_t k = 0; k < list.size(); ++k) {
      const auto it = std::find_if(formats.begin(), formats.end(), [&](const BoxFormat& f) { return f.name == list[k]; });
      if (it == formats.end())
        fail(ctx, names[k], index_path(fpath, k), "unknown format '" + list[k] + "' (not defined under formats)");
      r.formats.push_back(static_cast<int>(it - formats.begin()));
    }
    recipes.push_back(std::move(r));
  }
  return recipes;
}


std::optional<RegionOfInterest> read_roi(const Context& ctx, const YAML::Node& node, const std::string& path) {
  if (node.IsNull()) return std::nullopt;
  if (!node.IsMap()) fail(ctx, node, path, "expected a mapping {frame, min_m, max_m} or null, got " + describe(node));
  check_keys(ctx, node, path, {"frame", "min_m", "max_m"});
  RegionOfInterest roi;
  const YAML::Node frame = require(ctx, node, path, "frame");
  const std::string word = read_string(ctx, frame, join(path, "frame"));
  if (word != "base" && word != "camera") fail(ctx, frame, join(path, "frame"), "must be base or camera (not '" + word + "')");
  roi.frame = word == "base" ? RegionOfInterest::Frame::kBase : RegionOfInterest::Frame::kCamera;
  for (auto [key, out] : {std::pair<const char*, Eigen::Vector3d*>{"min_m", &roi.min_m}, {"max_m", &roi.max_m}}) {
    const YAML::Node v = require(ctx, node, path, key);
    const std::string vpath = join(path, key);
    if (!v.IsSequence() || v.size() != 3) fail(ctx, v, vpath, "expected a list of 3 numbers [x, y, z] in metres, got " + describe(v));
    for (std::size_t i = 0; i < 3; ++i) (*out)[static_cast<Eigen::Index>(i)] = read_double(ctx, v[i], index_path(vpath, i));
  }
  for (Eigen::Index i = 0; i < 3; ++i) {
    if (!(roi.min_m[i] < roi.max_m[i])) {
      fail(ctx, node["max_m"], join(path, "max_m"),
           std::string("must be above min_m on every axis (") + "xyz"[i] + ": " + std::to_string(roi.max_m[i]) +
               " <= " + std::to_string(roi.min_m[i]) + ")");
    }
  }
  return roi;
}

}  // namespace palletd::config_detail
