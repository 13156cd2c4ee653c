// Layout search: exact recovery of known layouts, noise, seams, ambiguity, paper mode.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "layout_fixtures.hpp"
#include "palletd/detection/layout.hpp"

using namespace palletd;
using namespace palletd::layout_test;

namespace {

LayoutParams params_for_tests() {
  LayoutParams p;
  p.search.time_budget_ms = 2000.0;  // generous: correctness here, speed in tests/bench
  return p;
}

/// Runs the search on the exact outline (optionally noisy, optionally with seams).
/// find_layout on the layout's outline (perturbed by noise_m and chamfer_m); with its seams, and
/// for a layout of several formats the tape along its cartons too (seams alone cannot show where
/// one carton stands rather than two pressed together).
LayoutResult run(const KnownLayout& l, const LayoutParams& p, bool with_seams, double noise_m = 0.0,
                 double chamfer_m = 0.0) {
  auto outline = union_outline(l);
  if (noise_m > 0 || chamfer_m > 0) outline = perturb(outline, noise_m, chamfer_m, 7U);
  SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
  if (l.formats.size() > 1) seams = taped(std::move(seams), l);
  return find_layout(outline, l.formats, p, with_seams ? &seams : nullptr);
}

}  // namespace

TEST_CASE("union outline of a pinwheel is a square with a square hole") {
  const auto outline = union_outline(pinwheel(0.4, 0.3, false));
  REQUIRE(outline.size() == 1);
  CHECK(outline[0].outer.size() == 4);
  REQUIRE(outline[0].holes.size() == 1);
  CHECK(area(outline[0]) == Approx(0.49 - 0.01).margin(1e-9));
}

TEST_CASE("clipped area of a polygon with holes against rectangles is exact") {
  const auto outline = union_outline(pinwheel(0.4, 0.3, false));
  CHECK(clipped_area(outline[0], -1, -1, 2, 2) == Approx(0.48).margin(1e-12));
  CHECK(clipped_area(outline[0], 0.25, 0.25, 0.45, 0.45) == Approx(0.04 - 0.01).margin(1e-12));
  CHECK(clipped_area(outline[0], 0.8, 0.8, 1.0, 1.0) == Approx(0.0).margin(1e-15));
}

TEST_CASE("exact recovery of known layouts from ideal outlines with seams") {
  const LayoutParams p = params_for_tests();
  std::vector<KnownLayout> layouts = {block(3, 3, 0.4, 0.3), brick(),       pinwheel(0.4, 0.3, false),
                                      pinwheel(0.4, 0.3, true), mixed_formats(), l_shaped(),
                                      clusters(),            grid_200x150(40)};
  for (auto l : layouts) {
    for (double theta : {0.0, 0.3}) {
      l.theta_rad = theta;
      l.offset = {0.1, -0.2};
      INFO(l.name << " theta " << theta);
      const LayoutResult r = run(l, p, true);
      REQUIRE(r.status == DetectionStatus::kOk);
      const double err = match_error(truth_boxes(l), r.boxes);
      CHECK(err >= 0.0);
      CHECK(err < 0.002);
      CHECK_FALSE(r.ambiguous);
      CHECK(r.coverage > 0.99);
      CHECK_FALSE(r.budget_exhausted);
    }
  }
}

TEST_CASE("a block with a unique tiling is found without seams and not flagged") {
  const KnownLayout l = block(3, 3, 0.4, 0.3);
  const LayoutResult r = run(l, params_for_tests(), false);
  REQUIRE(r.status == DetectionStatus::kOk);
  CHECK(match_error(truth_boxes(l), r.boxes) >= 0.0);
  CHECK_FALSE(r.ambiguous);
  REQUIRE_FALSE(r.boxes.empty());
  for (const LayoutBox& b : r.boxes) CHECK(b.score > 0.99);
}

TEST_CASE("pinwheel chirality: ambiguous from the outline, resolved by seams") {
  for (bool mirrored : {false, true}) {
    const KnownLayout l = pinwheel(0.4, 0.3, mirrored);
    const LayoutResult no_seams = run(l, params_for_tests(), false);
    REQUIRE(no_seams.status == DetectionStatus::kOk);
    CHECK(no_seams.ambiguous);
    CHECK(no_seams.runner_up.size() == 4);
    const LayoutResult seams = run(l, params_for_tests(), true);
    REQUIRE(seams.status == DetectionStatus::kOk);
    CHECK_FALSE(seams.ambiguous);
    CHECK(match_error(truth_boxes(l), seams.boxes) >= 0.0);
  }
}

TEST_CASE("noisy outlines: perturbed edges and rounded corners") {
  const LayoutParams p = params_for_tests();
  for (auto l : {block(3, 3, 0.4, 0.3), brick(), pinwheel(0.4, 0.3, true), l_shaped(), clusters(),
                 mixed_formats()}) {
    l.theta_rad = 0.1;
    INFO(l.name);
    const LayoutResult r = run(l, p, true, 0.002, 0.008);
    REQUIRE(r.status == DetectionStatus::kOk);
    const double err = match_error(truth_boxes(l), r.boxes);
    CHECK(err >= 0.0);
    CHECK(err < 0.006);
    CHECK_FALSE(r.ambiguous);
  }
}

TEST_CASE("area methods agree on the layout") {
  const KnownLayout l = brick();
  for (AreaMethod m : {AreaMethod::kGridSat, AreaMethod::kRaster, AreaMethod::kClip}) {
    LayoutParams p = params_for_tests();
    p.search.area_method = m;
    const LayoutResult r = run(l, p, true);
    REQUIRE(r.status == DetectionStatus::kOk);
    CHECK(match_error(truth_boxes(l), r.boxes) >= 0.0);
  }
}

TEST_CASE("paper mode finds the same layout as the best-first search on small cases") {
  LayoutParams paper = params_for_tests();
  paper.search.mode = SearchMode::kPaper;
  for (auto l : {block(2, 2, 0.4, 0.3), block(3, 1, 0.4, 0.3), l_shaped(), clusters()}) {
    INFO(l.name);
    if (l.name == "l-shaped") l.boxes.resize(4);  // keep the paper's queue small
    const LayoutResult a = run(l, paper, false);
    const LayoutResult b = run(l, params_for_tests(), false);
    REQUIRE(a.status == DetectionStatus::kOk);
    REQUIRE(b.status == DetectionStatus::kOk);
    CHECK_FALSE(a.budget_exhausted);
    CHECK(match_error(b.boxes, a.boxes) >= 0.0);
    CHECK(match_error(truth_boxes(l), a.boxes) >= 0.0);
    CHECK(a.score == Approx(b.score).margin(1e-6));
  }
}

TEST_CASE("paper mode reports its cap on a big layer") {
  LayoutParams paper = params_for_tests();
  paper.search.mode = SearchMode::kPaper;
  paper.search.paper_max_hypotheses = 5000;
  const LayoutResult r = run(grid_200x150(40), paper, false);
  CHECK(r.budget_exhausted);
  CHECK(r.hypotheses_visited >= 5000);
}

TEST_CASE("densely sampled jagged outlines keep their corners") {
  // Every edge resampled every 5 mm with +/-1.5 mm noise: no single edge is long any more.
  for (auto l : {block(3, 3, 0.4, 0.3), pinwheel(0.4, 0.3, false), l_shaped()}) {
    l.theta_rad = 0.2;
    INFO(l.name);
    std::mt19937 rng(9U);
    std::uniform_real_distribution<double> u(-0.0015, 0.0015);
    auto dense = [&](const Ring2d& r) {
      Ring2d out;
      for (std::size_t i = 0; i < r.size(); ++i) {
        const Eigen::Vector2d a = r[i], b = r[(i + 1) % r.size()];
        const int n = static_cast<int>((b - a).norm() / 0.005);
        for (int k = 0; k < n; ++k) {  // y before x, one draw per statement (gcc's order)
          const double dy = u(rng);
          const double dx = u(rng);
          out.push_back(a + (b - a) * (static_cast<double>(k) / n) + Eigen::Vector2d(dx, dy));
        }
      }
      return out;
    };
    std::vector<PolygonWithHoles> outline;
    for (const auto& p : union_outline(l)) {
      PolygonWithHoles q;
      q.outer = dense(p.outer);
      for (const auto& h : p.holes) q.holes.push_back(dense(h));
      outline.push_back(q);
    }
    const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
    const LayoutResult r = find_layout(outline, l.formats, params_for_tests(), &seams);
    REQUIRE(r.status == DetectionStatus::kOk);
    const double err = match_error(truth_boxes(l), r.boxes);
    CHECK(err >= 0.0);
    CHECK(err < 0.005);
  }
}

TEST_CASE("pinwheel chirality when the frame's own seams do not show: ambiguous, not picked by lines") {
  // Two pinwheels side by side. The gaps every candidate layout predicts (the pinwheels' outer
  // seams, the line between them) are pressed shut: they look like box tops. Faint lines run
  // where the mirrored pinwheels would have their seams (tape, print on the tops). Measured
  // against the frame's own seams those lines are not seams, so nothing inside the layer
  // separates the chiralities; summed along whole edges the lines would pick the mirrors.
  auto two = [](bool mirrored) {
    KnownLayout l = pinwheel(0.4, 0.3, mirrored);
    const auto one = l.boxes;
    for (TruthBox b : one) {
      b.x0 += 0.7;
      l.boxes.push_back(b);
    }
    return l;
  };
  const KnownLayout l = two(false), mirror = two(true);
  const SeamEvidence mirror_seams = synthetic_seams(mirror, 0.003, 0.002);
  const SeamEvidence true_seams = synthetic_seams(l, 0.003, 0.002);
  REQUIRE(mirror_seams.seam.size() == true_seams.seam.size());
  SeamEvidence lines = mirror_seams;
  std::mt19937 rng(5U);
  std::uniform_real_distribution<float> noise(0.f, 0.05f);
  for (std::size_t i = 0; i < lines.seam.size(); ++i) {
    const bool mirror_only = mirror_seams.seam[i] > 0.5f && true_seams.seam[i] < 0.5f;
    lines.seam[i] = (mirror_only ? 0.3f : 0.f) + noise(rng);
  }
  lines.strength = 0.1;
  const LayoutResult r = find_layout(union_outline(l), l.formats, params_for_tests(), &lines);
  REQUIRE(r.status == DetectionStatus::kOk);
  CHECK(r.ambiguous);
  // Real seams (every gap open) decide, for the layout they show.
  const LayoutResult c = find_layout(union_outline(l), l.formats, params_for_tests(), &mirror_seams);
  REQUIRE(c.status == DetectionStatus::kOk);
  CHECK_FALSE(c.ambiguous);
  CHECK(match_error(truth_boxes(mirror), c.boxes) >= 0.0);
}

namespace {

/// The ring with the convex corners of its short steps (an edge shorter than step_m) cut by
/// chamfers: step_leg_m along the step, side_leg_m along the other edge.
Ring2d chamfer_steps(const Ring2d& ring, double step_m, double step_leg_m, double side_leg_m) {
  const double orient = signed_area(ring) > 0 ? 1.0 : -1.0;
  Ring2d out;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const Eigen::Vector2d& a = ring[(i + ring.size() - 1) % ring.size()];
    const Eigen::Vector2d& b = ring[i];
    const Eigen::Vector2d& c = ring[(i + 1) % ring.size()];
    const Eigen::Vector2d u = b - a, v = c - b;
    const bool convex = orient * (u.x() * v.y() - u.y() * v.x()) > 0;
    if (!convex || (u.norm() >= step_m && v.norm() >= step_m)) {
      out.push_back(b);
      continue;
    }
    out.push_back(b - u.normalized() * (u.norm() < step_m ? step_leg_m : side_leg_m));
    out.push_back(b + v.normalized() * (v.norm() < step_m ? step_leg_m : side_leg_m));
  }
  return out;
}

}  // namespace

TEST_CASE("staggered edges traced at a coarse pitch: the outline tolerance keeps their boxes") {
  // Two rows of 300 x 200 boxes, the second offset by 100 mm: each end of the layer steps by
  // 100 mm. At a 20 mm pitch seen at 45 deg such a step comes out washed into a slope (as in a
  // simulated O3D303 frame at 176 x 132): here a chamfer of 80 mm along the step and 160 mm
  // along the box side, which leaves the end box 0.89 of its area inside the measured outline,
  // and the paper's A_min drops it.
  KnownLayout l{"staggered", {{0.3, 0.2, "A"}}, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 3; ++c) l.boxes.push_back({c * 0.3 + (r == 1 ? 0.1 : 0.0), r * 0.2, 0, true});
  }
  l.theta_rad = 0.2;
  auto outline = union_outline(l);
  REQUIRE(outline.size() == 1);
  outline[0].outer = chamfer_steps(outline[0].outer, 0.15, 0.08, 0.16);
  LayoutParams p = params_for_tests();
  p.search.outline_tolerance_m = 0.0;  // the outline taken as exact: boxes go missing
  const LayoutResult exact = find_layout(outline, l.formats, p, nullptr);
  CHECK(match_error(truth_boxes(l), exact.boxes) < 0.0);
  p.search.outline_tolerance_m = 0.01;  // half the pitch
  const LayoutResult tolerant = find_layout(outline, l.formats, p, nullptr);
  REQUIRE(tolerant.status == DetectionStatus::kOk);
  const double err = match_error(truth_boxes(l), tolerant.boxes);
  CHECK(err >= 0.0);
  CHECK(err < 0.003);
  CHECK_FALSE(tolerant.ambiguous);
  // The score stays the area inside the measured outline.
  CHECK(tolerant.score <= area(outline[0]) + 1e-9);
}

TEST_CASE("a lone box measured a pixel short on each axis is still a box") {
  // At a coarse pitch (17 mm) a lone 315 x 232 box's outline came out 300 x 220 (the mixed pixels
  // at its edges fall off the layer): no candidate line lay a box length from either side.
  const std::vector<BoxFormat> formats{{0.315, 0.232, "A"}};
  PolygonWithHoles lone;
  lone.outer = {{0.1, 0.2}, {0.4, 0.2}, {0.4, 0.42}, {0.1, 0.42}};
  LayoutParams p = params_for_tests();
  p.search.outline_tolerance_m = 0.0;
  CHECK(find_layout({lone}, formats, p, nullptr).boxes.empty());
  p.search.outline_tolerance_m = 0.0085;  // half the pitch
  const LayoutResult r = find_layout({lone}, formats, p, nullptr);
  REQUIRE(r.status == DetectionStatus::kOk);
  REQUIRE(r.boxes.size() == 1);
  CHECK_FALSE(r.ambiguous);
  // Placed from one of the seen sides (the refinement centres it on the outline).
  CHECK(std::abs(r.boxes[0].center.x() - 0.25) < 0.01);
  CHECK(std::abs(r.boxes[0].center.y() - 0.31) < 0.01);
}
