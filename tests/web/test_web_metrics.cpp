// GET /metrics on the status page's server and on a metrics-only server (the `metrics:` section).
#include <string>

#include <catch2/catch.hpp>

#include "palletd/web/web.hpp"

#include "web_fixture.hpp"

// After Eigen: httplib.h pulls in <resolv.h>, whose _res macro breaks Eigen's headers.
#include <httplib.h>

using namespace palletd;

namespace {

struct Started {
  WebServer server;
  httplib::Client client;
  Started(WebOptions o, StatusSource source)
      : server(std::move(o), std::move(source)), client("127.0.0.1", start()) {
    client.set_connection_timeout(5);
    client.set_read_timeout(10);
  }
  int start() {
    const Status s = server.start();
    INFO(s.error());
    REQUIRE(s.ok());
    return server.port();
  }
  int status_of(const char* path, const char* host = nullptr) {
    httplib::Headers headers;
    if (host != nullptr) headers.emplace("Host", host);
    auto r = client.Get(path, headers);
    REQUIRE(r);
    return r->status;
  }
};

WebOptions any_port(bool status_page) {
  WebOptions o;
  o.port = 0;
  o.status_page = status_page;
  return o;
}

}  // namespace

TEST_CASE("/metrics serves the source's text in the Prometheus format, 404 without a source",
          "[web][metrics]") {
  testing::WebFixture f;
  StatusSource source = f.source();
  int scrapes = 0;
  source.metrics = [&scrapes] {
    ++scrapes;
    return std::string("# TYPE palletd_triggers_total counter\npalletd_triggers_total 3\n");
  };
  Started page(any_port(true), source);
  auto r = page.client.Get("/metrics");
  REQUIRE(r);
  CHECK(r->status == 200);
  CHECK(r->get_header_value("Content-Type").rfind("text/plain; version=0.0.4", 0) == 0);
  CHECK(r->body.find("palletd_triggers_total 3") != std::string::npos);
  CHECK(scrapes == 1);  // rendered per request, never cached
  CHECK(page.status_of("/") == 200);

  Started without(any_port(true), f.source());
  CHECK(without.status_of("/metrics") == 404);
}

TEST_CASE("a metrics-only server answers /metrics alone, with the page's host rules", "[web][metrics]") {
  testing::WebFixture f;
  StatusSource source = f.source();
  source.metrics = [] { return std::string("palletd_camera_ok 1\n"); };
  WebOptions o = any_port(false);
  o.allowed_hosts = {"cell7.plant.example"};
  Started metrics(o, source);
  CHECK(metrics.status_of("/metrics") == 200);
  CHECK(metrics.status_of("/metrics", "cell7.plant.example") == 200);
  CHECK(metrics.status_of("/metrics", "attacker.example") == 403);
  for (const char* path : {"/", "/api/status", "/api/result", "/api/overlay.png"}) {
    INFO(path);
    CHECK(metrics.status_of(path) == 404);
  }
}
