// Runs the calling process in a private network namespace with only `lo` (up), so a fake
// GigE Vision camera can bind 127.0.0.1:3956 and its broadcast address without touching the
// host network.
#pragma once

#include <string>

namespace palletd::test {

/// "" on success (idempotent), else why a private network namespace is not available here.
std::string enter_private_netns();

}  // namespace palletd::test
