// Fuzz target: the Modbus TCP request path of the real server, end to end over loopback.
// Framing (MBAP), validation (request_check), the reply from the register map (libmodbus), and the
// PLC control handshake (writes to the control block -> events -> published results).
//
// Input: byte 0 = options (bit 0 service ready, bit 1 camera ok, bit 2 client is read-only,
// bit 3 server answers any unit id, bit 4 low word first), then records:
//   'S' u16 n <n bytes>  open a connection, send the bytes, half-close, read every reply until the
//                        server closes; the replies must match the requests one for one
//   'R' <20 bytes>       publish a result for the oldest pending trigger (status, boxes, values)
//   'T' <4 bytes>        publish a service status
// Any other tag ends the input. A fresh server per input keeps runs reproducible.
#include <arpa/inet.h>
#include <cerrno>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_util.hpp"
#include "palletd/modbus/server.hpp"

namespace {

using namespace palletd::modbus;
using palletd::fuzz::ByteReader;
using palletd::fuzz::fail;

unsigned u16_at(const std::string& s, std::size_t i) {
  return (static_cast<unsigned>(static_cast<unsigned char>(s[i])) << 8) |
         static_cast<unsigned char>(s[i + 1]);
}

/// What the server must answer: one reply per complete frame with protocol id 0, in order,
/// until the stream ends, a frame is incomplete, or a length is impossible (then it closes).
struct Expected {
  std::vector<unsigned> ids;
  bool server_closes = false;  ///< an impossible length: the server drops the connection
};
Expected expected_replies(const std::string& stream) {
  Expected e;
  std::size_t at = 0;
  while (stream.size() - at >= 7) {
    const unsigned length = u16_at(stream, at + 4);
    if (length < 2 || length > 254) {
      e.server_closes = true;
      break;
    }
    if (stream.size() - at < 6 + length) break;
    if (u16_at(stream, at + 2) == 0) e.ids.push_back(u16_at(stream, at));
    at += 6 + length;
  }
  return e;
}

/// A loopback source address of its own per input (127.x.y.z, never 127.0.0.1). Every exchange
/// half-closes first, so the client side of each connection ends in TIME_WAIT for a minute; at
/// thousands of inputs a second one source address runs out of ephemeral ports (connect fails
/// with EADDRNOTAVAIL, the listener's bind(0) with EADDRINUSE). Spreading the clients over the
/// 127/8 block keeps both free; the server only sees a peer address, which the read-only option
/// names.
std::string next_source_address() {
  static std::uint32_t counter = 0;
  const std::uint32_t n = counter++ % (254U * 254U * 254U);
  return "127." + std::to_string(1 + n / (254U * 254U)) + "." + std::to_string(1 + (n / 254U) % 254U) +
         "." + std::to_string(1 + n % 254U);
}

std::string errno_text(const std::string& what) { return what + ": " + std::strerror(errno); }

/// Connects a new socket from `source` to the server; EINTR (libFuzzer's timers) waits for the
/// connection to complete instead of failing.
int connect_from(const std::string& source, std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) fail(errno_text("socket"));
  const int on = 1;
  ::setsockopt(fd, IPPROTO_IP, IP_BIND_ADDRESS_NO_PORT, &on, sizeof on);  // port chosen at connect
  sockaddr_in local{};
  local.sin_family = AF_INET;
  if (::inet_pton(AF_INET, source.c_str(), &local.sin_addr) != 1) fail("source address " + source);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) fail(errno_text("bind " + source));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) return fd;
  if (errno != EINTR && errno != EINPROGRESS) fail(errno_text("connect from " + source));
  pollfd p{fd, POLLOUT, 0};
  while (::poll(&p, 1, 5000) < 0) {
    if (errno != EINTR) fail(errno_text("poll (connect)"));
  }
  int error = 0;
  socklen_t length = sizeof error;
  ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &length);
  if ((p.revents & POLLOUT) == 0 || error != 0) {
    errno = error != 0 ? error : ETIMEDOUT;
    fail(errno_text("connect from " + source));
  }
  return fd;
}

/// Sends `stream` on a new connection and returns everything the server sent back before closing.
std::string exchange(const std::string& source, std::uint16_t port, const std::string& stream) {
  const int fd = connect_from(source, port);
  std::string received;
  char buffer[4096];
  std::size_t sent = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  bool write_closed = false;
  for (;;) {
    if (sent == stream.size() && !write_closed) {
      ::shutdown(fd, SHUT_WR);
      write_closed = true;
    }
    pollfd p{fd, static_cast<short>(POLLIN | (write_closed ? 0 : POLLOUT)), 0};
    if (::poll(&p, 1, 100) < 0) {
      if (errno == EINTR) continue;  // libFuzzer's own timers
      fail(errno_text("poll"));
    }
    if ((p.revents & POLLOUT) != 0 && !write_closed) {
      const ssize_t n = ::send(fd, stream.data() + sent, stream.size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) sent += static_cast<std::size_t>(n);
      else if (n < 0 && errno != EAGAIN && errno != EINTR) write_closed = true;  // server closed early
    }
    if ((p.revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
      const ssize_t n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) break;
      if (n > 0) received.append(buffer, static_cast<std::size_t>(n));
    }
    if (std::chrono::steady_clock::now() > deadline) fail("the server neither answered nor closed within 10 s");
  }
  const linger abort_close{1, 0};  // RST: no TIME_WAIT pile-up over millions of runs
  ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &abort_close, sizeof abort_close);
  ::close(fd);
  return received;
}

void check_replies(const std::string& stream, const std::string& replies) {
  const Expected e = expected_replies(stream);
  const std::vector<unsigned>& expected = e.ids;
  // When the server drops the connection with bytes unread, the kernel resets it and replies
  // still in flight may be lost: then a prefix of the replies is all that can be asked for.
  const bool server_may_close = e.server_closes;
  std::vector<unsigned> got;
  std::size_t at = 0;
  while (replies.size() - at >= 8) {
    const unsigned length = u16_at(replies, at + 4);
    if (u16_at(replies, at + 2) != 0) fail("reply with protocol id != 0");
    if (length < 2 || replies.size() - at < 6 + length) fail("truncated or malformed reply frame");
    const auto function = static_cast<unsigned char>(replies[at + 7]);
    if ((function & 0x80U) != 0 && length != 3) fail("exception reply of the wrong length");
    got.push_back(u16_at(replies, at));
    at += 6 + length;
  }
  if (at != replies.size()) fail("trailing bytes after the last reply");
  if (got.size() > expected.size()) fail("more replies than requests");
  if (!server_may_close && got.size() != expected.size())
    fail("a request went unanswered: " + std::to_string(expected.size()) + " requests, " +
         std::to_string(got.size()) + " replies");
  for (std::size_t i = 0; i < got.size(); ++i) {
    if (got[i] != expected[i]) fail("reply out of order");
  }
}

ResultRecord make_result(ByteReader& in, const HandshakeEvent& event) {
  ResultRecord r;
  r.request_id = event.request_id;
  r.recipe = event.recipe;
  const std::uint8_t kind = in.u8();
  r.status = static_cast<ResultStatus>(kind % 3);
  r.error = static_cast<ErrorCode>((kind >> 2) % 8);
  r.error_detail = in.u16();
  const std::uint8_t boxes = in.u8();
  r.boxes_found = boxes;
  r.ambiguous = (kind & 0x20) != 0;
  r.budget_exhausted = (kind & 0x40) != 0;
  r.layer_clipped = (kind & 0x80) != 0;
  r.outline_unobserved = (kind & 0x01) != 0;
  // Values from the input, including NaN, infinities and absurd magnitudes.
  auto value = [&in] {
    const std::uint32_t bits = in.u32();
    float f = 0.0F;
    std::memcpy(&f, &bits, sizeof f);
    return static_cast<double>(f);
  };
  r.layer_z_m = value();
  r.coverage = value();
  r.processing_ms = value();
  for (int i = 0; i < boxes % 48; ++i) {
    BoxRecord b;
    b.x_m = r.layer_z_m * i;
    b.y_m = -r.coverage * i;
    b.z_m = r.layer_z_m;
    b.yaw_deg = r.processing_ms * i;
    b.format = static_cast<std::uint16_t>(i);
    b.score = r.coverage;
    b.pick_index = static_cast<std::uint16_t>(i + 1);
    r.boxes.push_back(b);
  }
  return r;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  const std::uint8_t options = in.u8();
  ServerOptions server_options;
  server_options.port = 0;
  server_options.unit_id = (options & 8) != 0 ? 0 : 1;
  const std::string source = next_source_address();
  if ((options & 4) != 0) server_options.read_only = {source};
  server_options.max_connections = 4;
  server_options.handshake.word_order =
      (options & 16) != 0 ? WordOrder::kLowWordFirst : WordOrder::kHighWordFirst;
  ModbusServer server(server_options);
  if (const palletd::Status started = server.start(); !started.ok()) fail("server start: " + started.error());
  auto status = std::make_shared<ServiceStatus>();
  status->ready = (options & 1) != 0;
  status->camera_ok = (options & 2) != 0;
  server.publish_status(status);

  std::deque<HandshakeEvent> triggers;
  auto collect_events = [&] {
    while (auto event = server.wait_event(std::chrono::milliseconds(0))) {
      if (event->kind == EventKind::kTrigger) triggers.push_back(*event);
    }
  };
  for (int record = 0; record < 16 && in.remaining() > 0; ++record) {
    const std::uint8_t tag = in.u8();
    if (tag == 'S') {
      const std::string stream = in.bytes(in.u16());
      const std::string replies = exchange(source, server.port(), stream);
      check_replies(stream, replies);
      collect_events();
    } else if (tag == 'R') {
      HandshakeEvent event;
      if (!triggers.empty()) {
        event = triggers.front();
        triggers.pop_front();
      }
      server.publish_result(std::make_shared<const ResultRecord>(make_result(in, event)));
    } else if (tag == 'T') {
      auto s = std::make_shared<ServiceStatus>();
      const std::uint8_t flags = in.u8();
      s->ready = (flags & 1) != 0;
      s->camera_ok = (flags & 2) != 0;
      s->poses_in_camera_frame = (flags & 4) != 0;
      s->error = static_cast<ErrorCode>((flags >> 3) % 8);
      s->error_detail = in.u16();
      s->acquisition_id = in.u8();
      server.publish_status(s);
    } else {
      break;
    }
  }
  // The register image must stay within what the map allows for the status word's defined bits.
  const RegisterImage image = server.registers();
  if ((image[kRegStatusWord] & ~0x1FFU) != 0) fail("undefined status word bits set");
  server.stop();
  return 0;
}
