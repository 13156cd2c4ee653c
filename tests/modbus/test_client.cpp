// PlcClient (the libmodbus PLC of palletctl and the tests) against a peer that accepts the
// connection and never answers: a request fails with its registers named, after the client's
// response timeout.
#include <chrono>

#include <arpa/inet.h>
#include <catch2/catch.hpp>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "palletd/modbus/client.hpp"

using namespace palletd::modbus;
using namespace std::chrono_literals;

namespace {

/// A loopback socket that listens and never reads: the kernel completes the connection, no
/// reply ever comes.
struct SilentPeer {
  int fd = -1;
  int port = 0;
  SilentPeer() {
    fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), len) != 0 || ::listen(fd, 4) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0)
      return;
    port = ntohs(addr.sin_port);
  }
  ~SilentPeer() {
    if (fd >= 0) ::close(fd);
  }
  SilentPeer(const SilentPeer&) = delete;
  SilentPeer& operator=(const SilentPeer&) = delete;
};

/// Seconds until a read of the status block fails, and its error.
double seconds_to_fail(PlcClient& client, std::string& error) {
  RegisterImage image{};
  const auto t0 = std::chrono::steady_clock::now();
  const palletd::Status read = client.read(kStatusStart, 4, image);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  REQUIRE_FALSE(read.ok());
  error = read.error();
  return s;
}

}  // namespace

TEST_CASE(
    "PlcClient: an unanswered request fails naming its registers - after the response timeout it was given") {
  SilentPeer peer;
  REQUIRE(peer.port > 0);
  std::string error;
  SECTION("the default waits 2 s") {
    PlcClient client("127.0.0.1", peer.port, 1);
    REQUIRE(client.connect().ok());
    CHECK(seconds_to_fail(client, error) >= 1.9);
  }
  SECTION("a longer timeout waits longer than the default") {
    PlcClient client("127.0.0.1", peer.port, 1);
    client.set_response_timeout(3500ms);
    REQUIRE(client.connect().ok());
    CHECK(seconds_to_fail(client, error) >= 3.4);
  }
  INFO(error);
  CHECK(error.find("reading registers " + std::to_string(kStatusStart)) != std::string::npos);
}
