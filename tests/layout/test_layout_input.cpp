// Layout search on bad input, budgets, refinement.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>

#include "layout_fixtures.hpp"
#include "palletd/detection/layout.hpp"

using namespace palletd;
using namespace palletd::layout_test;

namespace {

PolygonWithHoles rectangle(double w, double h) {
  PolygonWithHoles p;
  p.outer = {{0, 0}, {w, 0}, {w, h}, {0, h}};
  return p;
}

PolygonWithHoles disc(double r, int n) {
  PolygonWithHoles p;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    p.outer.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return p;
}

}  // namespace

TEST_CASE("formats larger than the layer: no_layout with a reason") {
  for (SearchMode mode : {SearchMode::kBestFirst, SearchMode::kPaper}) {
    LayoutParams p;
    p.search.mode = mode;
    const LayoutResult r = find_layout({rectangle(0.5, 0.4)}, {{0.6, 0.5, "big"}}, p, nullptr);
    CHECK(r.status == DetectionStatus::kNoLayout);
    CHECK_FALSE(r.reason.empty());
    CHECK(r.boxes.empty());
  }
}

TEST_CASE("zero, negative or swapped sizes: no_layout naming the format") {
  for (const BoxFormat& f : {BoxFormat{0.0, 0.2, "zero"}, BoxFormat{0.3, -0.2, "negative"},
                             BoxFormat{0.2, 0.3, "swapped"}, BoxFormat{NAN, 0.2, "nan"}}) {
    const LayoutResult r = find_layout({rectangle(1.2, 0.8)}, {f}, LayoutParams{}, nullptr);
    CHECK(r.status == DetectionStatus::kNoLayout);
    CHECK(r.reason.find(f.name) != std::string::npos);
  }
  const LayoutResult none = find_layout({rectangle(1.2, 0.8)}, {}, LayoutParams{}, nullptr);
  CHECK(none.status == DetectionStatus::kNoLayout);
}

TEST_CASE("an outline without orthogonal corners: no_layout") {
  for (SearchMode mode : {SearchMode::kBestFirst, SearchMode::kPaper}) {
    LayoutParams p;
    p.search.mode = mode;
    const LayoutResult r = find_layout({disc(0.5, 48)}, {{0.3, 0.2, "A"}}, p, nullptr);
    CHECK(r.status == DetectionStatus::kNoLayout);
    CHECK(r.reason.find("orthogonal corner") != std::string::npos);
  }
}

TEST_CASE("boxes that match no recipe format: no_layout") {
  // A layer of 400 x 300 boxes searched with a 500 x 330 recipe.
  const auto outline = union_outline(block(3, 3, 0.4, 0.3));
  LayoutParams p;
  p.search.time_budget_ms = 500;
  const LayoutResult r = find_layout(outline, {{0.5, 0.33, "wrong"}}, p, nullptr);
  CHECK(r.status == DetectionStatus::kNoLayout);
  CHECK(r.reason.find("match no recipe format") != std::string::npos);
}

TEST_CASE("the search ends within its budget and flags it") {
  // A noisy 40-box layer without seams, and a budget far too small to finish.
  const KnownLayout l = grid_200x150(40);
  const auto outline = perturb(union_outline(l), 0.002, 0.0, 3U);
  for (SearchMode mode : {SearchMode::kBestFirst, SearchMode::kPaper}) {
    LayoutParams p;
    p.search.mode = mode;
    p.search.time_budget_ms = 1.0;
    p.search.paper_max_hypotheses = 100000000;
    const auto t0 = std::chrono::steady_clock::now();
    const LayoutResult r = find_layout(outline, l.formats, p, nullptr);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    CHECK(ms < 1000.0);  // termination, not speed: the budget is 1 ms
    if (mode == SearchMode::kPaper) CHECK(r.budget_exhausted);
  }
}

TEST_CASE("several components are solved each alone") {
  const KnownLayout l = clusters();
  const auto outline = union_outline(l);
  REQUIRE(outline.size() == 3);
  const LayoutResult r = find_layout(outline, l.formats, LayoutParams{}, nullptr);
  REQUIRE(r.status == DetectionStatus::kOk);
  std::vector<int> per(3, 0);
  for (const LayoutBox& b : r.boxes) ++per[static_cast<std::size_t>(b.component)];
  std::sort(per.begin(), per.end());
  CHECK(per == std::vector<int>{1, 2, 3});
}

TEST_CASE("refinement moves boxes onto the measured outline and seams") {
  // Boxes with 5 mm gaps: the search places them flush from the outline's edges, so inner boxes
  // are off by up to a gap; refinement brings every centre within 2 mm.
  KnownLayout l = block(3, 2, 0.4, 0.3);
  l.gap_m = 0.005;
  l.theta_rad = 0.2;
  const auto outline = union_outline(l);
  const SeamEvidence seams = synthetic_seams(l, 0.002, 0.0015);
  LayoutParams p;
  p.search.time_budget_ms = 500;
  const LayoutResult found = find_layout(outline, l.formats, p, &seams);
  REQUIRE(found.status == DetectionStatus::kOk);
  const double before = match_error(truth_boxes(l), found.boxes);
  REQUIRE(before >= 0.0);
  LayerResult layer;
  layer.status = DetectionStatus::kOk;
  layer.polygons = outline;
  layer.points_2d = layer_points(l, 0.0025);
  const LayoutResult refined = refine_layout(found, layer, l.formats, &seams, p);
  const double after = match_error(truth_boxes(l), refined.boxes);
  REQUIRE(after >= 0.0);
  CHECK(after < 0.002);
  CHECK(after < before);
  for (const LayoutBox& b : refined.boxes) CHECK(b.score > 0.5);
}

TEST_CASE("per-box scores drop for a box crossed by a seam") {
  // Seams of the pinwheel, outline search without seams -> the mirrored layout has seams across
  // its boxes: their scores must be lower than the true layout's.
  const KnownLayout truth = pinwheel(0.4, 0.3, false);
  const KnownLayout mirror = pinwheel(0.4, 0.3, true);
  const SeamEvidence seams = synthetic_seams(truth, 0.003, 0.002);
  const auto outline = union_outline(truth);
  LayoutParams p;
  const LayoutResult good = find_layout(outline, truth.formats, p, &seams);
  REQUIRE(good.status == DetectionStatus::kOk);
  LayoutResult wrong = good;
  wrong.boxes.clear();
  for (const Box2d& b : truth_boxes(mirror)) wrong.boxes.push_back({b, 0.0, 0, false, {}});
  LayerResult layer;
  layer.status = DetectionStatus::kOk;
  layer.polygons = outline;
  p.refine.size_tolerance_m = 0.0;
  const LayoutResult rescored = refine_layout(wrong, layer, truth.formats, &seams, p);
  double good_min = 1, wrong_max = 0;
  for (const LayoutBox& b : good.boxes) good_min = std::min(good_min, b.score);
  for (const LayoutBox& b : rescored.boxes) wrong_max = std::max(wrong_max, b.score);
  CHECK(good_min > 0.8);
  CHECK(wrong_max < good_min);
}

TEST_CASE("formats of one size listed twice are one carton and not a tie: boxes take the first index") {
  // Two articles packed in the same carton: a recipe may list its size twice. The camera sees
  // the same top either way, so the layout is not in doubt between them.
  KnownLayout l = block(2, 2, 0.4, 0.3);
  const BoxFormat carton = l.formats.front();
  const BoxFormat other{0.5, 0.35, "500x350"};  // does not tile the layer
  for (const std::vector<BoxFormat>& formats :
       {std::vector<BoxFormat>{other, carton, carton}, std::vector<BoxFormat>{carton, other, carton}}) {
    const int first = formats.front().long_m == carton.long_m ? 0 : 1;
    const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
    const LayoutResult r = find_layout(union_outline(l), formats, LayoutParams{}, &seams);
    REQUIRE(r.status == DetectionStatus::kOk);
    std::vector<Box2d> truth = truth_boxes(l);
    for (Box2d& t : truth) t.format = first;
    CHECK(match_error(truth, r.boxes) >= 0.0);
    CHECK_FALSE(r.ambiguous);
  }
  // A size listed twice with a wrong side is still named by its own index.
  const LayoutResult bad =
      find_layout({rectangle(0.8, 0.6)}, {carton, carton, {0.2, 0.3, "swapped"}}, LayoutParams{}, nullptr);
  CHECK(bad.status == DetectionStatus::kNoLayout);
  CHECK(bad.reason.find("box format 2") != std::string::npos);
}
