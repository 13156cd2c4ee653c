#include "plc_load.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>
#include <thread>

#include "palletd/modbus/client.hpp"
#include "palletd/modbus/register_map.hpp"

#include "../modbus/raw_client.hpp"

namespace palletd::test {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

LatencySummary summarize(std::vector<double> v) {
  LatencySummary s;
  s.count = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  // Nearest rank, as palletctl trigger prints it.
  const auto rank = [&](double p) {
    const auto k = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
    return v[std::min(v.size() - 1, k == 0 ? 0 : k - 1)];
  };
  s.p50_ms = rank(0.50);
  s.p99_ms = rank(0.99);
  s.max_ms = v.back();
  return s;
}

namespace {

struct Shared {
  std::mutex mutex;
  LoadReport report;
  void error(const std::string& text) {
    std::lock_guard<std::mutex> lock(mutex);
    if (report.errors.size() < 20) report.errors.push_back(text);
  }
};

/// Sleeps until the next of a client's ticks `period` apart; behind, it does not burst to catch up.
void wait_next(Clock::time_point& next, Clock::duration period) {
  next += period;
  const auto now = Clock::now();
  if (next < now) next = now;
  std::this_thread::sleep_until(next);
}

void poller(const LoadOptions& o, const std::atomic<bool>& stop, Shared& shared) {
  auto client = std::make_unique<modbus::PlcClient>(o.host, o.port, o.unit_id);
  if (Status s = client->connect(); !s) {
    std::lock_guard<std::mutex> lock(shared.mutex);
    ++shared.report.poll_connect_errors;
    if (shared.report.errors.size() < 20) shared.report.errors.push_back("poller: " + s.error());
    return;
  }
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.poll_hz));
  modbus::RegisterImage image{};
  std::uint64_t cycles = 0, errors = 0, torn = 0;
  auto next = Clock::now();
  while (!stop.load()) {
    Status a = client->read(modbus::kStatusStart, modbus::kStatusCount, image);
    Status b = a ? client->read(modbus::kResultStart, modbus::kResultCount, image) : a;
    if (!a || !b) {
      ++errors;
      shared.error("poller: " + (a ? b.error() : a.error()));
      // A fresh connection (libmodbus may be out of step after a timeout).
      client = std::make_unique<modbus::PlcClient>(o.host, o.port, o.unit_id);
      if (!client->connect()) std::this_thread::sleep_for(50ms);
    } else {
      ++cycles;
      if (image[modbus::kRegResultId] != image[modbus::kResultIdCopy]) ++torn;
    }
    wait_next(next, period);
  }
  std::lock_guard<std::mutex> lock(shared.mutex);
  shared.report.poll_cycles += cycles;
  shared.report.poll_errors += errors;
  shared.report.torn_reads += torn;
}

/// The `k`-th bad request of a flooder: what a PLC program with a wrong address or a scanner
/// sends. The first four are answered with an exception; the last two make the server drop the
/// connection (a frame it cannot parse, half a frame).
std::vector<std::uint8_t> bad_request(std::uint64_t k) {
  using modbus::test::RawClient;
  const auto tid = static_cast<std::uint16_t>(k);
  switch (k % 6) {
    case 0:  // past the end of the map: illegal data address
      return RawClient::frame(tid, 1, RawClient::read_pdu(0x03, modbus::kRegisterCount, 10));
    case 1:  // a function the server does not offer: illegal function
      return RawClient::frame(tid, 1, RawClient::pdu(0x2B, 0, 0));
    case 2:  // 200 registers in one read: illegal data value
      return RawClient::frame(tid, 1, RawClient::read_pdu(0x03, 0, 200));
    case 3:  // a write to a read-only register
      return RawClient::frame(tid, 1, RawClient::pdu(0x06, modbus::kRegResultId, 1));
    case 4:  // another protocol id and a length past the frame's
      return RawClient::frame(tid, 1, RawClient::read_pdu(0x03, 0, 1), 7, 300);
    default: {  // half a frame, then the connection closed
      auto f = RawClient::frame(tid, 1, RawClient::read_pdu(0x03, 0, 1));
      f.resize(f.size() / 2);
      return f;
    }
  }
}

void flooder(const LoadOptions& o, int index, const std::atomic<bool>& stop, Shared& shared) {
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.flood_hz));
  std::uint64_t k = static_cast<std::uint64_t>(index), connections = 0, exceptions = 0, connect_errors = 0;
  auto next = Clock::now();
  while (!stop.load()) {
    {
      modbus::test::RawClient client(o.host, static_cast<std::uint16_t>(o.port));
      if (!client.connected() || !client.send(bad_request(k))) {
        ++connect_errors;
      } else {
        ++connections;
        const std::vector<std::uint8_t> answer = client.receive(std::chrono::milliseconds(100));
        if (answer.size() == 9 && (answer[7] & 0x80) != 0) ++exceptions;
      }
    }
    ++k;
    wait_next(next, period);
  }
  std::lock_guard<std::mutex> lock(shared.mutex);
  shared.report.flood_connections += connections;
  shared.report.flood_exceptions += exceptions;
  shared.report.flood_connect_errors += connect_errors;
}

}  // namespace

LoadReport run_load(const LoadOptions& o, const std::atomic<bool>* external_stop,
                    const std::function<void(const LoadReport&, const LatencySummary&)>& on_window) {
  Shared shared;
  std::atomic<bool> stop{false};
  std::vector<std::thread> pollers;
  pollers.reserve(static_cast<std::size_t>(o.pollers + o.flooders));
  for (int i = 0; i < o.pollers; ++i) pollers.emplace_back([&] { poller(o, stop, shared); });
  for (int i = 0; i < o.flooders; ++i) pollers.emplace_back([&, i] { flooder(o, i, stop, shared); });

  const auto start = Clock::now();
  const auto end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o.duration_s));
  const auto should_stop = [&] {
    return Clock::now() >= end || (external_stop != nullptr && external_stop->load());
  };
  if (o.trigger_period_ms > 0.0) {
    auto plc = std::make_unique<modbus::PlcClient>(o.host, o.port, o.unit_id);
    bool connected = plc->connect().ok();
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(o.trigger_period_ms));
    auto next = Clock::now();
    auto window_start = Clock::now();
    std::vector<double> window;
    std::uint16_t request_id = 1;
    int done = 0;
    while (!should_stop() && (o.triggers == 0 || done < o.triggers)) {
      std::this_thread::sleep_until(next);
      next += period;
      if (next < Clock::now()) next = Clock::now();
      if (!connected) {
        plc = std::make_unique<modbus::PlcClient>(o.host, o.port, o.unit_id);
        connected = plc->connect().ok();
        if (!connected) {
          std::lock_guard<std::mutex> lock(shared.mutex);
          ++shared.report.handshakes_failed;
          continue;
        }
      }
      auto r = plc->trigger(o.recipe, request_id,
                            std::chrono::milliseconds(static_cast<long>(o.handshake_timeout_ms)));
      request_id = static_cast<std::uint16_t>(request_id == 65535 ? 1 : request_id + 1);
      ++done;
      {
        std::lock_guard<std::mutex> lock(shared.mutex);
        if (r) {
          ++shared.report.handshakes_ok;
          shared.report.latencies_ms.push_back(r->handshake_ms);
          if (r->result.record.status == modbus::ResultStatus::kFailed) ++shared.report.results_failed;
          window.push_back(r->handshake_ms);
        } else {
          ++shared.report.handshakes_failed;
          if (shared.report.errors.size() < 20) shared.report.errors.push_back("plc: " + r.error());
        }
      }
      if (!r) connected = false;  // reconnect: the handshake may be out of step
      if (o.window_s > 0.0 && on_window && Clock::now() - window_start >= std::chrono::duration<double>(o.window_s)) {
        LoadReport copy;
        {
          std::lock_guard<std::mutex> lock(shared.mutex);
          copy = shared.report;
        }
        copy.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
        on_window(copy, summarize(window));
        window.clear();
        window_start = Clock::now();
      }
    }
  } else {
    while (!should_stop()) std::this_thread::sleep_for(20ms);
  }
  stop = true;
  for (auto& t : pollers) t.join();
  shared.report.elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
  return shared.report;
}

}  // namespace palletd::test
