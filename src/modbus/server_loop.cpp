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
    if (connections_.size() >= static_cast<std::size_t>(options_.max_connections)) {
      // Longest idle first, but a connection that never sent a request goes before one that did:
      // a burst of silent connections must not push out the PLC between two of its polls.
      auto oldest = std::min_element(connections_.begin(), connections_.end(),
                                     [](const auto& a, const auto& b) {
                                       if ((a->requests == 0) != (b->requests == 0)) return a->requests == 0;
                                       return a->last_activity < b->last_activity;
                                     });
      log("modbus: connection cap reached; closing the longest idle one from " + (*oldest)->peer);
      connections_.erase(oldest);
      ++stats_.connections_evicted;
    }
    const int on = 1;
    setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    auto c = std::make_unique<Connection>();
    c->fd = std::move(fd);
    c->peer = name;
    c->read_only = !read_only_.empty() && read_only_.matches(address);
    c->last_activity = now;
    connections_.push_back(std::move(c));
    ++stats_.connections_accepted;
    log("modbus: connection from " + name);
  }
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
    if (modbus_reply_exception(ctx_.get(), frame, exception) < 0) c.closing = true;
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
