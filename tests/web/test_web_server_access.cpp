// The status page server's access rules over loopback: what it refuses and how it fails to start.
#include <string>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "palletd/web/web.hpp"

#include "web_fixture.hpp"
#include "web_server_helpers.hpp"

using namespace palletd;
using namespace palletd::testing;
using Json = nlohmann::json;

TEST_CASE("unknown paths, missing results and missing files answer 404") {
  testing::WebFixture f;
  Running run(f, test_options());
  for (const char* path : {"/nothing", "/api/nothing", "/api/frame/other.png", "/api/frame/intensity.png"}) {
    auto r = run.client.Get(path);
    REQUIRE(r);
    INFO(path);
    CHECK(r->status == 404);
  }
  f.set_latest(nullptr);
  for (const char* path :
       {"/api/result", "/api/overlay.png", "/api/frame/depth.png", "/api/frame/meta.json"}) {
    auto r = run.client.Get(path);
    REQUIRE(r);
    INFO(path);
    CHECK(r->status == 404);
    CHECK(Json::parse(r->body).contains("error"));
  }
  const Json j = get_json(run.client, "/api/status");
  CHECK(j["last_result"].is_null());
}

TEST_CASE("the server is read-only: other methods are refused") {
  testing::WebFixture& f = shared_fixture();
  Running run(f, test_options(true));
  auto put = run.client.Put("/api/status", "{}", "application/json");
  REQUIRE(put);
  CHECK(put->status >= 400);
  auto post = run.client.Post("/api/result", "{}", "application/json");
  REQUIRE(post);
  CHECK(post->status >= 400);
  auto del = run.client.Delete("/api/snapshot");
  REQUIRE(del);
  CHECK(del->status >= 400);
}

TEST_CASE("POST /api/snapshot is refused unless allowed, then passed to the service") {
  testing::WebFixture& f = shared_fixture();
  const int before = f.snapshot_requests;
  SECTION("not allowed: 403 and the service is not asked") {
    Running run(f, test_options(false));
    auto r = run.client.Post("/api/snapshot", "", "text/plain");
    REQUIRE(r);
    CHECK(r->status == 403);
    CHECK(f.snapshot_requests == before);
    CHECK(get_json(run.client, "/api/status")["snapshot_post_allowed"] == false);
  }
  SECTION("allowed: 202 and one request per POST") {
    Running run(f, test_options(true));
    auto r = run.client.Post("/api/snapshot", "", "text/plain");
    REQUIRE(r);
    CHECK(r->status == 202);
    CHECK(Json::parse(r->body)["requested"] == true);
    CHECK(f.snapshot_requests == before + 1);
    REQUIRE(run.client.Post("/api/snapshot", "", "text/plain"));
    CHECK(f.snapshot_requests == before + 2);
  }
  SECTION("allowed, but from another site's page: 403") {
    Running run(f, test_options(true));
    httplib::Headers headers{{"Origin", "http://evil.example"}};
    auto r = run.client.Post("/api/snapshot", headers, "", "text/plain");
    REQUIRE(r);
    CHECK(r->status == 403);
    CHECK(f.snapshot_requests == before);
  }
  SECTION("allowed, but the service cannot store snapshots: 501") {
    StatusSource src = f.source();
    src.request_snapshot = nullptr;
    Running run(f, test_options(true), src);
    auto r = run.client.Post("/api/snapshot", "", "text/plain");
    REQUIRE(r);
    CHECK(r->status == 501);
  }
  SECTION("allowed, and the service says no: 503 with its reason") {
    StatusSource src = f.source();
    src.request_snapshot = []() -> Status { return Error{"recording folder is full"}; };
    Running run(f, test_options(true), src);
    auto r = run.client.Post("/api/snapshot", "", "text/plain");
    REQUIRE(r);
    CHECK(r->status == 503);
    CHECK(Json::parse(r->body)["error"] == "recording folder is full");
  }
}

TEST_CASE("processing time and latency percentiles come from the results seen, each counted once") {
  testing::WebFixture f;
  f.set_latest(nullptr);
  WebOptions o = test_options();
  o.stats_window = 100;
  Running run(f, o);
  std::shared_ptr<ResultSnapshot> last;
  for (int i = 1; i <= 150; ++i) {  // the first 50 drop out of the window
    auto s = std::make_shared<ResultSnapshot>(f.first());
    s->trigger_seq = static_cast<std::uint64_t>(100 + i);
    s->latency_ms = static_cast<double>(i);
    s->detection.timing_ms["total"] = static_cast<double>(2 * i);
    run.server.observe(s);
    run.server.observe(s);  // seen twice, counted once
    last = s;
  }
  f.set_latest(last);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the sampler sees it too
  const Json j = get_json(run.client, "/api/status");
  CHECK(j["counters"]["window"] == 100);
  CHECK(j["counters"]["latency_ms"]["p50"].get<double>() == Approx(100.0));  // values 51..150
  CHECK(j["counters"]["latency_ms"]["p99"].get<double>() == Approx(149.0));
  CHECK(j["counters"]["processing_ms"]["p50"].get<double>() == Approx(200.0));
  CHECK(j["counters"]["processing_ms"]["p99"].get<double>() == Approx(298.0));
}

TEST_CASE("a taken port or a bad source fails start() with the reason") {
  testing::WebFixture& f = shared_fixture();
  Running first(f, test_options());
  WebOptions o = test_options();
  o.port = first.server.port();
  WebServer second(o, f.source());
  const Status s = second.start();
  CHECK_FALSE(s.ok());
  CHECK(s.error().find(std::to_string(o.port)) != std::string::npos);

  WebServer bad(test_options(), StatusSource{});
  CHECK_FALSE(bad.start().ok());
  bad.stop();  // idempotent, nothing to stop
  first.server.stop();
  first.server.stop();
}

TEST_CASE("requests naming a foreign host are refused (DNS rebinding)") {
  testing::WebFixture& f = shared_fixture();
  WebOptions o = test_options();
  o.allowed_hosts = {"cellpc.example"};
  Running run(f, o);
  const std::string port = std::to_string(run.server.port());
  for (const std::string& host :
       std::vector<std::string>{"127.0.0.1:" + port, "localhost:" + port, "LocalHost", "[::1]:" + port,
                                "cellpc.example:" + port, "10.1.2.3"}) {
    auto r = run.client.Get("/api/status", httplib::Headers{{"Host", host}});
    REQUIRE(r);
    INFO(host);
    CHECK(r->status == 200);
  }
  for (const std::string& host : std::vector<std::string>{"evil.example:" + port, "evil.example",
                                                          "127.0.0.1.evil.example", "[nonsense"}) {
    auto r = run.client.Get("/", httplib::Headers{{"Host", host}});
    REQUIRE(r);
    INFO(host);
    CHECK(r->status == 403);
  }
}
