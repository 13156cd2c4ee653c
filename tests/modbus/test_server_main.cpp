// Test fixture (not shipped): the Modbus server plus the handshake, answering each trigger with
// fake_result() after --delay-ms. Prints "PORT <n>" once listening; stops on SIGTERM/SIGINT.
//   palletd_modbus_test_server [--bind ADDR] [--port N] [--low-word-first] [--delay-ms MS]
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include "fake_result.hpp"
#include "palletd/modbus/server.hpp"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
  using namespace palletd::modbus;
  ServerOptions options;
  options.bind_address = "127.0.0.1";
  options.port = 0;
  options.idle_timeout_s = 30.0;
  int delay_ms = 30;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--bind" && has_value) {
      options.bind_address = argv[++i];
    } else if (arg == "--port" && has_value) {
      options.port = static_cast<std::uint16_t>(std::atoi(argv[++i]));
    } else if (arg == "--delay-ms" && has_value) {
      delay_ms = std::atoi(argv[++i]);
    } else if (arg == "--low-word-first") {
      options.handshake.word_order = WordOrder::kLowWordFirst;
    } else {
      std::fprintf(stderr, "unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  ModbusServer server(options);
  const auto started = server.start();
  if (!started) {
    std::fprintf(stderr, "%s\n", started.error().c_str());
    return 1;
  }
  auto status = std::make_shared<ServiceStatus>();
  status->ready = true;
  status->camera_ok = true;
  status->frames_grabbed = 0x00010002u;  // exercises the word order of 115-116
  server.publish_status(status);
  std::printf("PORT %u\n", static_cast<unsigned>(server.port()));
  std::fflush(stdout);
  while (g_stop == 0) {
    const auto event = server.wait_event(std::chrono::milliseconds(100));
    if (!event || event->kind != EventKind::kTrigger) continue;
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    server.publish_result(
        std::make_shared<const ResultRecord>(test::fake_result(event->recipe, event->request_id)));
  }
  server.stop();
  return 0;
}
