// palletd web: the JSON documents of the status page, built from plain values (no I/O).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "palletd/modbus/register_map.hpp"
#include "palletd/status/snapshot.hpp"
#include "palletd/web/web.hpp"

namespace palletd::web {

using Json = nlohmann::ordered_json;

/// The register blocks with addresses (0-based and 4xxxx), raw values and their meaning:
/// {"word_order", "blocks": [{"name", "title", "rows": [{address, ref, name, raw, value, meaning}]}],
///  "boxes": [{slot, address, x_mm, y_mm, z_mm, yaw_deg, format, score, pick_index}]}.
Json registers_json(const modbus::RegisterImage& image, modbus::WordOrder order);

struct Figures {  ///< rolling-window figures of the server
  std::size_t window = 0;
  std::optional<double> processing_p50_ms, processing_p99_ms, latency_p50_ms, latency_p99_ms;
};

/// The /api/status document.
Json status_json(const ServiceHealth& health, const modbus::RegisterImage& image, modbus::WordOrder order,
                 const ResultSnapshot* latest, const std::vector<RecipeInfo>& recipes, const Figures& figures,
                 bool snapshot_post_allowed, int refresh_ms);

/// The /api/result document: the detection line of detections.md with "frame" = `stem`, plus
/// "trigger" (seq, request id, recipe, error, latency, time), "poses_in" and the box table rows
/// the page shows ("table").
Json result_json(const ResultSnapshot& snapshot, const std::string& stem, const std::vector<RecipeInfo>& recipes);

/// The stem the last frame's files carry when downloaded ("palletd-<camera>-<seq>").
std::string snapshot_stem(const ResultSnapshot& snapshot);

/// ISO 8601 UTC with milliseconds.
std::string iso_time(std::chrono::system_clock::time_point t);

}  // namespace palletd::web
