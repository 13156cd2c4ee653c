#include "netns.hpp"

#include <net/if.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace palletd::test {

namespace {

std::string bring_loopback_up() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::string("socket: ") + std::strerror(errno);
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
  std::string result;
  if (::ioctl(fd, SIOCGIFFLAGS, &ifr) != 0) {
    result = std::string("SIOCGIFFLAGS lo: ") + std::strerror(errno);
  } else {
    ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP | IFF_RUNNING);
    if (::ioctl(fd, SIOCSIFFLAGS, &ifr) != 0) result = std::string("SIOCSIFFLAGS lo: ") + std::strerror(errno);
  }
  ::close(fd);
  return result;
}

std::string enter_once() {
  if (::unshare(CLONE_NEWNET) != 0) {
    const int first = errno;
    // Unprivileged: a user namespace gives CAP_NET_ADMIN over a new network namespace.
    if (::unshare(CLONE_NEWUSER | CLONE_NEWNET) != 0) {
      return std::string("unshare(CLONE_NEWNET): ") + std::strerror(first) +
             "; unshare(CLONE_NEWUSER|CLONE_NEWNET): " + std::strerror(errno);
    }
  }
  return bring_loopback_up();
}

}  // namespace

std::string enter_private_netns() {
  static const std::string result = enter_once();
  return result;
}

}  // namespace palletd::test
