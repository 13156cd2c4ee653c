// palletctl trigger: the PLC's handshake once (or --count times) over Modbus TCP, printing the
// boxes exactly as a PLC reads them from the result block.
#include <algorithm>
#include <cstdio>
#include <vector>
#include <string>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "palletd/results/evaluation.hpp"
#include "palletd/modbus/client.hpp"

namespace palletd {

namespace {

struct TriggerArgs {
  std::string host = "127.0.0.1";
  int port = 502;
  int unit = 1;
  int recipe = 1;
  int request_id = 1;
  int count = 1;
  int timeout_ms = 10000;
  bool quiet = false;  ///< no box tables, the summary only
  int picked_box = 0;    ///< --check-box: PickCheck with this box slot + 1 instead of a Trigger
  int picked_group = 0;  ///< --check-group: ... with this group slot + 1
};

const char* check_word(modbus::CheckResult c) {
  switch (c) {
    case modbus::CheckResult::kNone: return "none";
    case modbus::CheckResult::kPickOk: return "pick_ok";
    case modbus::CheckResult::kBoxStillThere: return "box_still_there";
    case modbus::CheckResult::kExtraBoxGone: return "extra_box_gone";
    case modbus::CheckResult::kNeighbourMoved: return "neighbour_moved";
  }
  return "?";
}

const char* status_word(modbus::ResultStatus s) {
  switch (s) {
    case modbus::ResultStatus::kOk: return "ok";
    case modbus::ResultStatus::kNoBoxes: return "no boxes";
    case modbus::ResultStatus::kFailed: return "failed";
  }
  return "?";
}

void print_result(const modbus::PlcClient::TriggerResult& r) {
  const modbus::ResultRecord& rec = r.result.record;
  std::printf("result %u (request %u, recipe %u): %s, %u box(es) found, %zu reported, coverage %.3f, "
              "layout confidence %.3f, layer z %.1f mm, poses in the %s frame, handshake %.0f ms\n",
              r.result.result_id, rec.request_id, rec.recipe, status_word(rec.status), rec.boxes_found,
              rec.boxes.size(), rec.coverage, rec.layout_confidence, rec.layer_z_m * 1000.0,
              r.status.poses_in_camera_frame ? "camera" : "base", r.handshake_ms);
  if (rec.status == modbus::ResultStatus::kFailed) {
    std::printf("  error code %u, detail %u\n", static_cast<unsigned>(r.status.error), r.status.error_detail);
    if (rec.best_recipe != 0) std::printf("  the frame shows the cartons of recipe %u\n", rec.best_recipe);
  }
  std::string flags;
  if (rec.ambiguous) flags += " ambiguous";
  if (rec.budget_exhausted) flags += " search-budget-exhausted";
  if (rec.layer_clipped) flags += " layer-clipped-by-image-border";
  if (rec.outline_unobserved) flags += " outline-partly-unobserved";
  if (!flags.empty()) std::printf("  flags:%s\n", flags.c_str());
  if (rec.check)
    std::printf("  pick check: %s, %u box(es) gone, %u moved (most: slot %u by %.1f mm)\n",
                check_word(rec.check->result), rec.check->boxes_gone, rec.check->boxes_moved,
                rec.check->moved_slot, rec.check->largest_move_m * 1000.0);
  if (rec.boxes.empty()) return;
  std::printf("  %4s %10s %10s %10s %9s %6s %6s\n", "pick", "x[mm]", "y[mm]", "z[mm]", "yaw[deg]", "format", "score");
  for (const auto& b : rec.boxes) {
    std::printf("  %4u %10.1f %10.1f %10.1f %9.2f %6u %6.3f\n", b.pick_index, b.x_m * 1000.0, b.y_m * 1000.0,
                b.z_m * 1000.0, b.yaw_deg, b.format, b.score);
  }
}

int run_trigger(const TriggerArgs& a) {
  modbus::PlcClient plc(a.host, a.port, a.unit);
  if (Status s = plc.connect(); !s) {
    spdlog::error("{}", s.error());
    return 1;
  }
  int failures = 0;
  std::vector<double> handshake_ms;
  for (int i = 0; i < a.count; ++i) {
    const auto request = static_cast<std::uint16_t>((a.request_id + i) & 0xFFFF);
    const std::chrono::milliseconds timeout(a.timeout_ms);
    auto result = a.picked_box > 0 || a.picked_group > 0
                      ? plc.pick_check(static_cast<std::uint16_t>(a.picked_box),
                                       static_cast<std::uint16_t>(a.picked_group), request, timeout)
                      : plc.trigger(static_cast<std::uint16_t>(a.recipe), request, timeout);
    if (!result) {
      spdlog::error("trigger {}: {}", request, result.error());
      ++failures;
      continue;
    }
    handshake_ms.push_back(result->handshake_ms);
    if (!a.quiet) print_result(*result);
    std::fflush(stdout);
    if (result->result.record.status == modbus::ResultStatus::kFailed) ++failures;
  }
  if (a.count > 1) {
    // The same interpolating percentile as `palletctl eval` and the benchmarks.
    auto pct = [&](double p) { return handshake_ms.empty() ? 0.0 : percentile(handshake_ms, p); };
    const double max_ms = handshake_ms.empty() ? 0.0 : *std::max_element(handshake_ms.begin(), handshake_ms.end());
    std::printf("%d trigger(s), %d failed; trigger-to-ResultReady p50 %.1f ms, p99 %.1f ms, max %.1f ms\n", a.count,
                failures, pct(50), pct(99), max_ms);
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

void register_trigger(CLI::App& app) {
  auto args = std::make_shared<TriggerArgs>();
  CLI::App* cmd = app.add_subcommand("trigger", "Do the PLC's trigger handshake over Modbus TCP and print the boxes");
  cmd->add_option("--host", args->host, "palletd host")->capture_default_str();
  cmd->add_option("--port", args->port, "Modbus TCP port")->capture_default_str()->check(CLI::Range(1, 65535));
  cmd->add_option("--unit", args->unit, "Modbus unit id")->capture_default_str()->check(CLI::Range(0, 255));
  cmd->add_option("--recipe", args->recipe, "recipe number")->capture_default_str()->check(CLI::Range(0, 65535));
  cmd->add_option("--request-id", args->request_id, "first request id")->capture_default_str()->check(CLI::Range(0, 65535));
  cmd->add_option("-n,--count", args->count, "number of triggers")->capture_default_str()->check(CLI::Range(1, 1000000));
  cmd->add_option("--timeout-ms", args->timeout_ms, "timeout per handshake [ms]")->capture_default_str();
  cmd->add_option("--check-box", args->picked_box,
                  "check a pick instead (control bit 5): the box slot + 1 the robot took (register 4)")
      ->check(CLI::Range(1, 32));
  cmd->add_option("--check-group", args->picked_group,
                  "check a pick instead: the group slot + 1 the robot took (register 5)")
      ->check(CLI::Range(1, 32));
  cmd->add_flag("-q,--quiet", args->quiet, "print only the latency summary (with --count > 1)");
  cmd->callback([args] { throw CLI::RuntimeError(run_trigger(*args)); });
}

}  // namespace palletd
