// The Modbus server's poll loop: accepting, framing, validating and answering requests.
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "request_check.hpp"
#include "server_impl.hpp"

namespace palletd::modbus {

using namespace detail;

void ModbusServer::Impl::absorb_published(Clock::time_point now) {
  if (!pending_.exchange(false)) return;
  std::deque<std::shared_ptr<const ResultRecord>> results;
  std::shared_ptr<const ServiceStatus> status;
  {
    std::lock_guard<std::mutex> lock(published_mutex_);
    results.swap(pending_results_);
    status = std::move(pending_status_);
  }
  if (status) handshake_->on_service_status(*status);
  for (const auto& result : results) handshake_->on_result(*result, now);
}

void ModbusServer::Impl::sync_mapping() {
  if (handshake_->version() == synced_version_) return;
  synced_version_ = handshake_->version();
  const RegisterImage& image = handshake_->registers();
  std::copy(image.begin(), image.end(), mapping_->tab_registers);
  std::copy(image.begin(), image.end(), mapping_->tab_input_registers);
}

void ModbusServer::Impl::push_events(const std::vector<HandshakeEvent>& events) {
  if (events.empty()) return;
  {
    std::lock_guard<std::mutex> lock(events_mutex_);
    for (const HandshakeEvent& e : events) {
      events_.push_back(e);
      if (events_.size() > options_.max_queued_events) {
        events_.pop_front();
        ++stats_.events_dropped;
      }
    }
  }
  events_cv_.notify_all();
}

void ModbusServer::Impl::publish_copies() {
  stats_.open_connections = connections_.size();
  stats_.missed_triggers = handshake_->missed_total();
  stats_.plc_heartbeat_lost = handshake_->plc_heartbeat_lost();
  std::lock_guard<std::mutex> lock(image_mutex_);
  image_copy_ = handshake_->registers();
  stats_copy_ = stats_;
}

int ModbusServer::Impl::poll_timeout_ms(Clock::time_point now) const {
  Clock::time_point deadline = std::min(now + kMaxPollWait, handshake_->next_tick());
  if (options_.idle_timeout_s > 0.0) {
    const auto idle = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(options_.idle_timeout_s));
    for (const auto& c : connections_) deadline = std::min(deadline, c->last_activity + idle);
  }
  if (deadline <= now) return 0;
  return static_cast<int>(
      std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count() + 1);
}

void ModbusServer::Impl::run() {
  std::vector<pollfd> fds;
  while (running_) {
    fds.clear();
    fds.push_back({wake_fd_.get(), POLLIN, 0});
    fds.push_back({listen_fd_.get(), POLLIN, 0});
    for (const auto& c : connections_) fds.push_back({c->fd.get(), POLLIN, 0});
    const int rc = ::poll(fds.data(), fds.size(), poll_timeout_ms(Clock::now()));
    const auto now = Clock::now();
    last_alive_ = now.time_since_epoch().count();
    if (rc < 0 && errno != EINTR) {
      log("modbus server: poll failed: " + errno_text());
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      continue;
    }
    if (rc > 0 && (fds[0].revents & POLLIN) != 0) {
      std::uint64_t count = 0;
      [[maybe_unused]] const ssize_t n = ::read(wake_fd_.get(), &count, sizeof count);
    }
    absorb_published(now);
    handshake_->tick(now);
    sync_mapping();
    publish_copies();  // registers() shows what the replies below will show
    if (rc > 0) {
      const std::size_t polled = fds.size() - 2;  // connections_ as they were when polled
      for (std::size_t i = 0; i < polled; ++i) {
        const short revents = fds[i + 2].revents;
        if (revents == 0) continue;
        Connection& c = *connections_[i];
        if ((revents & (POLLIN | POLLHUP | POLLERR)) != 0) serve(c, now);
        if ((revents & POLLNVAL) != 0) c.closing = true;
      }
    }
    if (options_.idle_timeout_s > 0.0) {
      const auto idle = std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(options_.idle_timeout_s));
      for (auto& c : connections_) {
        if (!c->closing && now - c->last_activity >= idle) {
          c->closing = true;
          ++stats_.connections_idle_closed;
          log("modbus: closing idle connection from " + c->peer);
        }
      }
    }
    connections_.erase(std::remove_if(connections_.begin(), connections_.end(),
                                      [](const auto& c) { return c->closing; }),
                       connections_.end());
    if (rc > 0 && (fds[1].revents & POLLIN) != 0) accept_all(now);
    update_connection_registers();
    publish_copies();
  }
}

void ModbusServer::Impl::accept_all(Clock::time_point now) {
  for (;;) {
    sockaddr_storage peer{};
    socklen_t length = sizeof peer;
    const int raw = ::accept4(listen_fd_.get(), reinterpret_cast<sockaddr*>(&peer), &length,
                              SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (raw < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) log("modbus server: accept: " + errno_text());
      return;
    }
    UniqueFd fd(raw);
    const auto* address = reinterpret_cast<const sockaddr*>(&peer);
    const std::string name = address_to_string(address);
    if (!allow_.empty() && !allow_.matches(address)) {
      ++stats_.connections_refused;
      log("modbus: refused connection from " + name + " (not on the allow list)");
      continue;
    }
    if (connections_.size() >= static_cast<std::size_t>(options_.max_connections)) evict_one();
    const int on = 1;
    setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    auto c = std::make_unique<Connection>();
    c->fd = std::move(fd);
    c->peer = name;
    c->read_only = !read_only_.empty() && read_only_.matches(address);
    c->last_activity = now;
    connections_.push_back(std::move(c));
    ++stats_.connections_accepted;
    // Clients that were evicted reconnect at their poll rate: their connections are counted only.
    if (evicted_peers_.count(name) == 0) log("modbus: connection from " + name);
  }
}

void ModbusServer::Impl::evict_one() {
  // Longest idle first, but a connection that never sent a request goes before one that did:
  // a burst of silent connections must not push out the PLC between two of its polls.
  auto oldest = std::min_element(connections_.begin(), connections_.end(),
                                 [](const auto& a, const auto& b) {
                                   if ((a->requests == 0) != (b->requests == 0)) return a->requests == 0;
                                   return a->last_activity < b->last_activity;
                                 });
  const std::string peer = (*oldest)->peer;
  connections_.erase(oldest);
  ++stats_.connections_evicted;
  // The first eviction per address is logged; the rest show in registers 140-141 and the metrics
  // (32 pollers over a cap of 16 evict thousands of times a minute). The set is bounded.
  constexpr std::size_t kMaxRemembered = 1024;
  if (evicted_peers_.count(peer) != 0 || evicted_peers_.size() >= kMaxRemembered) return;
  evicted_peers_.insert(peer);
  log("modbus: connection cap reached (modbus.max_connections = " + std::to_string(options_.max_connections) +
      "): closed the longest idle connection, from " + peer +
      "; its further evictions are counted in registers 140-141, not logged. Raise the cap to the "
      "number of clients that poll at once.");
}

void ModbusServer::Impl::update_connection_registers() {
  ConnectionCounters c;
  c.evicted = static_cast<std::uint32_t>(stats_.connections_evicted);  // wraps at 2^32
  c.refused = static_cast<std::uint32_t>(stats_.connections_refused);
  c.open = static_cast<std::uint16_t>(std::min<std::size_t>(connections_.size(), 65535));
  c.max_connections = static_cast<std::uint16_t>(std::clamp(options_.max_connections, 0, 65535));
  handshake_->on_connections(c);
  sync_mapping();
}

void ModbusServer::Impl::reply_exception(Connection& c, const std::uint8_t* frame,
                                         std::uint8_t code) {
  const std::uint8_t function = frame[detail::kMbapLength];
  if (function < 0x80) {
    if (modbus_reply_exception(ctx_.get(), frame, code) < 0) c.closing = true;
    return;
  }
  // Function codes 0x80..0xFF: libmodbus answers fc + 0x80 in 8 bits (0x83 -> 0x03, which reads
  // as a normal reply). The application protocol's exception keeps the top bit set: 0x80 | fc.
  const std::uint8_t reply[9] = {frame[0], frame[1], 0, 0, 0, 3, frame[6], function, code};
  const ssize_t sent = ::send(c.fd.get(), reply, sizeof reply, MSG_NOSIGNAL);
  if (sent != static_cast<ssize_t>(sizeof reply)) c.closing = true;
}

void ModbusServer::Impl::serve(Connection& c, Clock::time_point now) {
  std::uint8_t chunk[kReadChunk];
  std::size_t total = 0;
  while (!c.closing && total < kMaxReadPerWakeup) {
    const ssize_t n = ::recv(c.fd.get(), chunk, sizeof chunk, 0);
    if (n == 0) {
      c.closing = true;
      break;
    }
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) c.closing = true;
      break;
    }
    total += static_cast<std::size_t>(n);
    c.buffer.insert(c.buffer.end(), chunk, chunk + n);
    // Handle every complete frame; keep a partial one for later.
    std::size_t offset = 0;
    while (!c.closing && c.buffer.size() - offset >= detail::kMbapLength) {
      const std::uint8_t* frame = c.buffer.data() + offset;
      const unsigned length = u16(frame + 4);  // unit id + PDU
      if (length < 2 || length > detail::kMaxPduLength + 1) {
        log("modbus: impossible frame length " + std::to_string(length) + " from " + c.peer +
            "; closing");
        c.closing = true;
        break;
      }
      const std::size_t size = 6 + length;
      if (c.buffer.size() - offset < size) break;
      handle_frame(c, frame, size, now);
      offset += size;
    }
    c.buffer.erase(c.buffer.begin(), c.buffer.begin() + static_cast<std::ptrdiff_t>(
                                                            std::min(offset, c.buffer.size())));
  }
}

void ModbusServer::Impl::handle_frame(Connection& c, const std::uint8_t* frame, std::size_t size,
                                      Clock::time_point now) {
  ++stats_.requests;
  ++c.requests;
  c.last_activity = now;
  if (u16(frame + 2) != 0) {  // protocol id: not Modbus
    ++stats_.frames_dropped;
    return;
  }
  // Between two requests: take over what the service published since.
  absorb_published(now);
  sync_mapping();
  modbus_set_socket(ctx_.get(), c.fd.get());
  const std::uint8_t unit = frame[6];
  std::uint8_t exception = 0;
  if (options_.unit_id != 0 && unit != options_.unit_id) {
    exception = detail::kExGatewayTargetFailed;
  } else {
    exception = detail::check_request(frame + detail::kMbapLength, size - detail::kMbapLength,
                                      c.read_only);
  }
  if (exception != 0) {
    ++stats_.exceptions;
    ++stats_.exceptions_by_code[exception & 0x0Fu];
    reply_exception(c, frame, exception);
    return;
  }
  const std::uint8_t function = frame[detail::kMbapLength];
  // Coils mirror the control word, discrete inputs the status word.
  for (int bit = 0; bit < 16; ++bit) {
    mapping_->tab_bits[bit] = static_cast<std::uint8_t>((mapping_->tab_registers[kRegControlWord] >> bit) & 1u);
    mapping_->tab_input_bits[bit] = static_cast<std::uint8_t>((mapping_->tab_registers[kRegStatusWord] >> bit) & 1u);
  }
  if (modbus_reply(ctx_.get(), frame, static_cast<int>(size), mapping_.get()) < 0) {
    log("modbus: cannot answer " + c.peer + ": " + modbus_strerror(errno) + "; closing");
    c.closing = true;
  }
  if (!detail::is_write_function(function)) return;
  if (function == detail::kWriteSingleCoil || function == detail::kWriteMultipleCoils) {
    std::uint16_t word = 0;
    for (int bit = 0; bit < 16; ++bit) {
      if (mapping_->tab_bits[bit] != 0) word = static_cast<std::uint16_t>(word | (1u << bit));
    }
    mapping_->tab_registers[kRegControlWord] = word;
  }
  push_events(handshake_->on_control_written(mapping_->tab_registers + kControlStart, now));
  sync_mapping();
  publish_copies();
}

}  // namespace palletd::modbus
