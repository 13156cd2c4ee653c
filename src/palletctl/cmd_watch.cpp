// palletctl watch: the status block (registers 100..117) and the result header live in the
// terminal, read over Modbus TCP exactly as a PLC reads them (read-only: nothing is written).
// On a terminal the block is redrawn in place; otherwise one line per poll (for logs and scripts).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"
#include "palletd/modbus/register_words.hpp"

namespace palletd {

namespace {

struct WatchArgs {
  std::string host = "127.0.0.1";
  int port = 502;
  int unit = 1;
  int interval_ms = 200;
  int count = 0;  ///< polls; 0 = until interrupted
  bool lines = false;  ///< one line per poll even on a terminal
};

std::string now_text() {
  const auto now = std::chrono::system_clock::now();
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count();
  const auto secs = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  localtime_r(&secs, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%02d:%02d:%02d.%03d", tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms % 1000));
  return buf;
}

const char* state_word(std::uint16_t status_word) {
  if (status_word & modbus::kStError) return "ERROR";
  if (status_word & modbus::kStBusy) return "busy";
  if (status_word & modbus::kStReady) return "ready";
  return "NOT READY";
}

const char* result_status_word(std::uint16_t v) {
  switch (v) {
    case 0: return "ok";
    case 1: return "no boxes";
    case 2: return "failed";
    default: return "?";
  }
}

struct Poll {
  modbus::StatusRecord st;
  modbus::WordOrder order = modbus::WordOrder::kHighWordFirst;
  std::uint32_t pattern = 0;
  std::uint16_t result_id = 0, result_request = 0, result_status = 0, boxes = 0, recipe_used = 0;
};

Expected<Poll> poll_once(modbus::PlcClient& plc) {
  modbus::RegisterImage image{};
  if (Status s = plc.read(modbus::kStatusStart, modbus::kStatusCount, image); !s) return Error{s.error()};
  if (Status s = plc.read(modbus::kResultStart, modbus::kResultHeaderCount, image); !s) return Error{s.error()};
  Poll p;
  // The server says which word order it uses (format flags, register 109).
  p.order = (image[modbus::kRegFormatFlags] & modbus::kFmtLowWordFirst) ? modbus::WordOrder::kLowWordFirst
                                                                         : modbus::WordOrder::kHighWordFirst;
  p.st = modbus::decode_status(image, p.order);
  p.pattern = modbus::get_u32(&image[modbus::kRegTestPattern], p.order);
  p.result_id = image[modbus::kRegResultId];
  p.result_request = image[modbus::kRegResultRequestId];
  p.result_status = image[modbus::kRegResultStatus];
  p.boxes = image[modbus::kRegBoxesReported];
  p.recipe_used = image[modbus::kRegRecipeUsed];
  return p;
}

std::string error_text(const modbus::StatusRecord& st) {
  if (st.error == modbus::ErrorCode::kNone) return "0 (no error)";
  return std::to_string(static_cast<unsigned>(st.error)) + " " + modbus::error_name(st.error) + ", detail " +
         std::to_string(st.error_detail) + ": " + modbus::error_sentence(st.error, st.error_detail);
}

std::string one_line(const Poll& p) {
  const modbus::StatusRecord& st = p.st;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%s | %s | error %s | heartbeat %u | result %u (request %u, %s, %u boxes, recipe %u) | "
                "recipe %u | missed %u | processing %.0f ms | latency %.0f ms | frames %u | reconnects %u",
                state_word(st.status_word), modbus::bits_in_words(st.status_word, modbus::status_bit_names()).c_str(),
                error_text(st).c_str(), st.heartbeat, p.result_id, p.result_request,
                result_status_word(p.result_status), p.boxes, p.recipe_used, st.active_recipe, st.missed_triggers,
                st.processing_ms, st.latency_ms, st.frames_grabbed, st.camera_reconnects);
  return buf;
}

std::vector<std::string> block(const WatchArgs& a, const Poll& p, int polls) {
  const modbus::StatusRecord& st = p.st;
  std::vector<std::string> out;
  char buf[512];
  std::snprintf(buf, sizeof buf, "palletd at %s:%d (unit %d)   %s   poll %d   Ctrl-C to stop", a.host.c_str(), a.port,
                a.unit, now_text().c_str(), polls);
  out.emplace_back(buf);
  out.emplace_back(std::string("state        ") + state_word(st.status_word));
  std::string bits;
  const auto& names = modbus::status_bit_names();
  for (std::size_t i = 0; i < names.size(); ++i) {
    const bool on = (st.status_word & (1u << i)) != 0;
    bits += on ? "\x1b[1;7m " + names[i] + " \x1b[0m " : "\x1b[2m " + names[i] + " \x1b[0m ";
  }
  out.push_back("status word  " + bits);
  out.push_back("error        " + error_text(st));
  std::snprintf(buf, sizeof buf, "heartbeat    %u", st.heartbeat);
  out.emplace_back(buf);
  std::snprintf(buf, sizeof buf, "result       id %u, request %u, %s, %u boxes reported, recipe %u", p.result_id,
                p.result_request, result_status_word(p.result_status), p.boxes, p.recipe_used);
  out.emplace_back(buf);
  std::snprintf(buf, sizeof buf, "recipe       %u active; last request id %u; acquisition %u", st.active_recipe,
                st.last_request_id, st.acquisition_id);
  out.emplace_back(buf);
  std::snprintf(buf, sizeof buf, "counters     missed triggers %u, frames %u, camera reconnects %u", st.missed_triggers,
                st.frames_grabbed, st.camera_reconnects);
  out.emplace_back(buf);
  std::snprintf(buf, sizeof buf, "timing       processing %.0f ms, trigger to result %.0f ms", st.processing_ms,
                st.latency_ms);
  out.emplace_back(buf);
  std::snprintf(buf, sizeof buf, "format       %s, poses in the %s frame, test pattern 0x%08X%s",
                p.order == modbus::WordOrder::kLowWordFirst ? "low word first" : "high word first",
                st.poses_in_camera_frame ? "camera" : "robot base", static_cast<unsigned>(p.pattern),
                p.pattern == modbus::kTestPattern ? " (ok)" : " (WRONG: check the word order)");
  out.emplace_back(buf);
  return out;
}

int run_watch(const WatchArgs& a) {
  const bool tty = !a.lines && isatty(STDOUT_FILENO) != 0;
  std::unique_ptr<modbus::PlcClient> plc;
  std::size_t drawn = 0;  // lines of the last block on the terminal
  int failures = 0;
  for (int polls = 1; a.count == 0 || polls <= a.count; ++polls) {
    const auto next = std::chrono::steady_clock::now() + std::chrono::milliseconds(a.interval_ms);
    std::string problem;
    if (!plc) {
      plc = std::make_unique<modbus::PlcClient>(a.host, a.port, a.unit);
      if (Status s = plc->connect(); !s) problem = s.error();
    }
    Expected<Poll> p = problem.empty() ? poll_once(*plc) : Expected<Poll>(Error{problem});
    if (!p) {
      plc.reset();  // reconnect on the next poll
      ++failures;
    }
    if (tty) {
      std::vector<std::string> lines =
          p ? block(a, *p, polls) : std::vector<std::string>{now_text() + "  no answer: " + p.error(), "retrying..."};
      if (drawn > 0) std::printf("\x1b[%zuA\x1b[J", drawn);  // back to the block's first line, clear below
      for (const auto& line : lines) std::printf("%s\n", line.c_str());
      drawn = lines.size();
    } else if (p) {
      std::printf("%s %s\n", now_text().c_str(), one_line(*p).c_str());
    } else {
      std::printf("%s no answer: %s\n", now_text().c_str(), p.error().c_str());
    }
    std::fflush(stdout);
    if (a.count != 0 && polls == a.count) break;
    std::this_thread::sleep_until(next);
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

void register_watch(CLI::App& app) {
  auto args = std::make_shared<WatchArgs>();
  CLI::App* cmd = app.add_subcommand("watch", "Show palletd's Modbus status block live (read-only)");
  cmd->add_option("--host", args->host, "palletd host")->capture_default_str();
  cmd->add_option("--port", args->port, "Modbus TCP port")->capture_default_str()->check(CLI::Range(1, 65535));
  cmd->add_option("--unit", args->unit, "Modbus unit id")->capture_default_str()->check(CLI::Range(0, 255));
  cmd->add_option("--interval-ms", args->interval_ms, "time between polls [ms]")
      ->capture_default_str()
      ->check(CLI::Range(10, 60000));
  cmd->add_option("-n,--count", args->count, "stop after this many polls (0 = until Ctrl-C)")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000000));
  cmd->add_flag("--lines", args->lines, "one line per poll even on a terminal");
  cmd->callback([args] { throw CLI::RuntimeError(run_watch(*args)); });
}

}  // namespace palletd
