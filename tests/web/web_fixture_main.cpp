// palletd_web_fixture (test fixture, not installed): serves the status page for a real detection
// of one frame with a fake service behind it, for the browser test.
//   palletd_web_fixture [--frame STEM] [--port N]
// Prints "port N" on stdout once it serves, then runs until SIGTERM or SIGINT.
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include <pthread.h>

#include "palletd/web/web.hpp"
#include "web_fixture.hpp"

int main(int argc, char** argv) {
  std::string frame;
  int port = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--frame") == 0) frame = argv[i + 1];
    else if (std::strcmp(argv[i], "--port") == 0) port = std::stoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "usage: %s [--frame STEM] [--port N]\n", argv[0]);
      return 2;
    }
  }
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  try {
    palletd::testing::WebFixture fixture(frame);
    std::fprintf(stderr, "fixture: %s, %zu boxes\n", palletd::to_string(fixture.first().detection.status),
                 fixture.first().detection.boxes.size());
    palletd::WebOptions options;
    options.port = port;
    options.log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
    palletd::WebServer server(options, fixture.source());
    if (palletd::Status s = server.start(); !s) {
      std::fprintf(stderr, "%s\n", s.error().c_str());
      return 1;
    }
    std::printf("port %d\n", server.port());
    std::fflush(stdout);
    int sig = 0;
    sigwait(&signals, &sig);
    server.stop();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fixture: %s\n", e.what());
    return 1;
  }
  return 0;
}
