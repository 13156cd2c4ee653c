#include "palletd/modbus/server.hpp"

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

Status ModbusServer::Impl::start() {
  if (started_) return Error{"modbus server: start() may be called once"};
  started_ = true;
  if (!wake_fd_.valid()) return Error{"modbus server: eventfd: " + errno_text()};
  auto allow = AddressFilter::parse(options_.allow);
  if (!allow) return Error{allow.error()};
  auto read_only = AddressFilter::parse(options_.read_only);
  if (!read_only) return Error{read_only.error()};
  allow_ = std::move(*allow);
  read_only_ = std::move(*read_only);
  if (options_.max_connections < 1) return Error{"modbus server: max_connections must be >= 1"};

  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string port_text = std::to_string(options_.port);
  const int gai = getaddrinfo(options_.bind_address.c_str(), port_text.c_str(), &hints, &found);
  if (gai != 0) {
    return Error{"modbus server: cannot resolve bind address '" + options_.bind_address +
                 "': " + gai_strerror(gai)};
  }
  std::unique_ptr<addrinfo, decltype(&freeaddrinfo)> list(found, &freeaddrinfo);
  std::string last_error = "no address";
  for (const addrinfo* ai = found; ai != nullptr; ai = ai->ai_next) {
    UniqueFd fd(::socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0));
    if (!fd.valid()) {
      last_error = errno_text();
      continue;
    }
    const int on = 1, off = 0;
    setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
    if (ai->ai_family == AF_INET6) setsockopt(fd.get(), IPPROTO_IPV6, IPV6_V6ONLY, &off, sizeof off);
    if (::bind(fd.get(), ai->ai_addr, ai->ai_addrlen) != 0 || ::listen(fd.get(), SOMAXCONN) != 0) {
      last_error = errno_text();
      continue;
    }
    sockaddr_storage bound{};
    socklen_t length = sizeof bound;
    getsockname(fd.get(), reinterpret_cast<sockaddr*>(&bound), &length);
    port_ = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                              : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
    listen_fd_ = std::move(fd);
    break;
  }
  if (!listen_fd_.valid()) {
    return Error{"modbus server: cannot listen on [" + options_.bind_address + "]:" + port_text +
                 ": " + last_error};
  }
  ctx_.reset(modbus_new_tcp("127.0.0.1", 502));  // never connects: only frames replies
  mapping_.reset(modbus_mapping_new_start_address(0, 16, 0, 16, 0, kRegisterCount, 0, kRegisterCount));
  if (!ctx_ || !mapping_) return Error{"modbus server: out of memory"};

  const auto now = Clock::now();
  handshake_.emplace(options_.handshake, now);
  absorb_published(now);
  update_connection_registers();
  publish_copies();
  last_alive_ = now.time_since_epoch().count();
  running_ = true;
  thread_ = std::thread([this] { run(); });
  return {};
}

void ModbusServer::Impl::stop() {
  if (thread_.joinable()) {
    running_ = false;
    wake();
    thread_.join();
  }
  connections_.clear();
  listen_fd_.reset();
  {
    std::lock_guard<std::mutex> lock(events_mutex_);
    events_closed_ = true;
  }
  events_cv_.notify_all();
}

// ---- public interface ----

ModbusServer::ModbusServer(ServerOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}
ModbusServer::~ModbusServer() { stop(); }

Status ModbusServer::start() { return impl_->start(); }
void ModbusServer::stop() { impl_->stop(); }
std::uint16_t ModbusServer::port() const { return impl_->port_; }

void ModbusServer::publish_result(std::shared_ptr<const ResultRecord> result) {
  if (!result) return;
  {
    std::lock_guard<std::mutex> lock(impl_->published_mutex_);
    impl_->pending_results_.push_back(std::move(result));
  }
  impl_->pending_ = true;
  impl_->wake();
}

void ModbusServer::publish_status(std::shared_ptr<const ServiceStatus> status) {
  if (!status) return;
  {
    std::lock_guard<std::mutex> lock(impl_->published_mutex_);
    impl_->pending_status_ = std::move(status);
  }
  impl_->pending_ = true;
  impl_->wake();
}

std::optional<HandshakeEvent> ModbusServer::wait_event(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(impl_->events_mutex_);
  impl_->events_cv_.wait_for(lock, timeout,
                             [this] { return !impl_->events_.empty() || impl_->events_closed_; });
  if (impl_->events_.empty()) return std::nullopt;
  HandshakeEvent e = impl_->events_.front();
  impl_->events_.pop_front();
  return e;
}

RegisterImage ModbusServer::registers() const {
  std::lock_guard<std::mutex> lock(impl_->image_mutex_);
  return impl_->image_copy_;
}

ServerStats ModbusServer::stats() const {
  std::lock_guard<std::mutex> lock(impl_->image_mutex_);
  return impl_->stats_copy_;
}

std::chrono::steady_clock::time_point ModbusServer::last_alive() const {
  return Clock::time_point(Clock::duration(impl_->last_alive_.load()));
}

}  // namespace palletd::modbus
