// What the status page server tests share: options for a test server on any loopback port, a
// running server with its client, one fixture detection per test executable, a JSON GET.
#pragma once

#include <chrono>
#include <string>
#include <utility>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "palletd/web/web.hpp"

#include "web_fixture.hpp"

// After Eigen: httplib.h pulls in <resolv.h>, whose _res macro breaks Eigen's headers.
#include <httplib.h>

namespace palletd::testing {

inline WebOptions test_options(bool allow_post = false) {
  WebOptions o;
  o.port = 0;  // any free port, loopback (the default bind address)
  o.allow_snapshot_post = allow_post;
  o.sample_period = std::chrono::milliseconds(20);
  return o;
}

struct Running {
  WebFixture& fixture;
  WebServer server;
  httplib::Client client;
  Running(WebFixture& f, WebOptions o, StatusSource src)
      : fixture(f), server(std::move(o), std::move(src)), client("127.0.0.1", start_port()) {
    client.set_connection_timeout(5);
    client.set_read_timeout(10);
  }
  Running(WebFixture& f, WebOptions o) : Running(f, std::move(o), f.source()) {}
  int start_port() {
    const Status s = server.start();
    INFO(s.error());
    REQUIRE(s.ok());
    REQUIRE(server.port() > 0);
    return server.port();
  }
};

inline WebFixture& shared_fixture() {
  static WebFixture fixture;  // one detection for the whole executable
  return fixture;
}

inline nlohmann::json get_json(httplib::Client& c, const std::string& path, int want_status = 200) {
  auto r = c.Get(path.c_str());
  REQUIRE(r);
  CHECK(r->status == want_status);
  CHECK(r->get_header_value("Content-Type") == "application/json");
  return nlohmann::json::parse(r->body);
}

}  // namespace palletd::testing
