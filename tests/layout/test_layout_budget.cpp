// The deterministic search budget, footprint moves decided by the seams (mixed formats), and
// the box-side walk shared by the seam scorers.
#include <algorithm>
#include <cstdint>
#include <limits>

#include <catch2/catch.hpp>

#include "palletd/detection/layout.hpp"

#include "evidence/seam_likelihood.hpp"
#include "frame_boxes.hpp"
#include "layout_fixtures.hpp"
#include "layout_internal.hpp"
#include "search/best_first_internal.hpp"

using namespace palletd;
using namespace palletd::layout_test;
using namespace palletd::layout_detail;

namespace {

constexpr double kNoCap = std::numeric_limits<double>::infinity();  ///< absent seams uncapped

bool same_boxes(const std::vector<LayoutBox>& a, const std::vector<LayoutBox>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].center != b[i].center || a[i].yaw_rad != b[i].yaw_rad || a[i].format != b[i].format) return false;
  }
  return true;
}

/// 1200 x 600 of 400 x 300 (A) and 300 x 200 (B, turned, two side by side = one A): every A
/// could be two Bs and every pair of Bs an A by the outline alone.
KnownLayout mixed_rows() {
  KnownLayout l{"mixed rows", {{0.4, 0.3, "A"}, {0.3, 0.2, "B"}}, {}, 0.0, Eigen::Vector2d(0.1, -0.2), 0.0};
  l.theta_rad = 0.3;
  l.boxes = {{0.0, 0.0, 0, true}, {0.4, 0.0, 1, false}, {0.6, 0.0, 1, false}, {0.8, 0.0, 0, true},
             {0.0, 0.3, 1, false}, {0.2, 0.3, 1, false}, {0.4, 0.3, 0, true}, {0.8, 0.3, 1, false},
             {1.0, 0.3, 1, false}};
  return l;
}

}  // namespace

TEST_CASE("the expansion budget gives the same result twice, whatever the clock") {
  const KnownLayout l = grid_200x150(40);
  const auto outline = perturb(union_outline(l), 0.002, 0.0, 3U);
  LayoutParams p;
  p.search.time_budget_ms = 60000.0;  // the clock never decides here
  p.search.search_expansions = 30;    // far too small for 40 boxes
  const LayoutResult a = find_layout(outline, l.formats, p, nullptr);
  const LayoutResult b = find_layout(outline, l.formats, p, nullptr);
  CHECK(a.budget_exhausted);
  CHECK(b.budget_exhausted);
  CHECK(a.hypotheses_visited == b.hypotheses_visited);
  CHECK(a.status == b.status);
  CHECK(same_boxes(a.boxes, b.boxes));

  LayoutParams full;
  full.search.time_budget_ms = 60000.0;
  const LayoutResult c = find_layout(outline, l.formats, full, nullptr);
  CHECK_FALSE(c.budget_exhausted);  // the default finishes a 40-box layer
  CHECK(c.hypotheses_visited > a.hypotheses_visited);
  CHECK((c.ambiguous || match_error(truth_boxes(l), c.boxes) >= 0.0));  // no seams: grid ties are flagged
}

TEST_CASE(
    "a wide recipe's search by the seams ends well before its budget on a block of its largest format") {
  // Four 600 x 400 in two by two and a recipe of five formats, three of which divide 600 x 400
  // (400 x 300, 300 x 200, 200 x 150): the outline alone cannot tell them apart. The seams between
  // the cartons show faintly (a coarse camera), and every side between two boxes costs what its
  // seam lacks. The bound charges the cells still to fill the least such cost a box over them can
  // have, so the search need not open every split of the four cartons before it takes them whole.
  KnownLayout l = block(2, 2, 0.6, 0.4);
  l.formats = {{0.6, 0.4, "600x400"},
               {0.4, 0.3, "400x300"},
               {0.3, 0.2, "300x200"},
               {0.315, 0.232, "315x232"},
               {0.2, 0.15, "200x150"}};
  SeamEvidence faint = synthetic_seams(l, 0.008, 0.004);
  for (float& v : faint.seam) v *= 0.5F;
  LayoutParams p;
  p.search.time_budget_ms = 60000.0;  // the expansion budget decides, not the clock
  const LayoutResult r = find_layout(union_outline(l), l.formats, p, &faint);
  REQUIRE(r.status == DetectionStatus::kOk);
  CHECK_FALSE(r.budget_exhausted);
  CHECK(r.search_expansions < p.search.search_expansions / 10);
  CHECK(match_error(truth_boxes(l), r.boxes) >= 0.0);
  for (const LayoutBox& b : r.boxes) CHECK(b.format == 0);
}

TEST_CASE("searches that reuse one memory find what searches with memory of their own find") {
  // Each layer searched with its own memory, then twice on memories every search before filled
  // (a 40-box layer first, the largest): one that keeps all it took, one with a 256 kB budget (512 nodes)
  // that the larger searches outgrow. No node, frontier entry or queued item of one search may reach
  // the next; the first keeps what it took, the second holds exactly its budget afterwards.
  const std::vector<KnownLayout> layers{grid_200x150(40), mixed_rows(), pinwheel(0.4, 0.3, false), l_shaped(),
                                        brick()};
  LayoutParams p;
  p.search.time_budget_ms = 60000.0;  // the clock never decides here
  SearchMemory all;
  constexpr std::size_t kBudgetBytes = std::size_t{256} << 10;
  SearchMemory budgeted(kBudgetBytes, 512);
  const std::size_t budget_words = budgeted.storage().pool.capacity();
  CHECK(budget_words == kBudgetBytes / sizeof(std::uint64_t));
  bool outgrown = false;
  for (const KnownLayout& l : layers) {
    const auto outline = perturb(union_outline(l), 0.002, 0.0, 5U);
    const LayoutResult own = find_layout(outline, l.formats, p, nullptr);
    REQUIRE(own.hypotheses_visited > 0);
    for (SearchMemory* memory : {&all, &budgeted, &all, &budgeted}) {
      const LayoutResult reused = find_layout(outline, l.formats, p, nullptr, nullptr, memory);
      CHECK(reused.hypotheses_visited == own.hypotheses_visited);
      CHECK(reused.status == own.status);
      CHECK(reused.ambiguous == own.ambiguous);
      CHECK(same_boxes(reused.boxes, own.boxes));
    }
    CHECK(budgeted.storage().pool.capacity() == budget_words);
    outgrown = outgrown || all.storage().pool.capacity() > budget_words;
  }
  CHECK(outgrown);  // the budget was too small for some search, and given back after it
  // The largest search came first: the later ones found room in what it left.
  const auto& storage = all.storage();
  const std::uint64_t* pool_after = storage.pool.data();
  const std::size_t capacity = storage.pool.capacity();
  const KnownLayout& first = layers.front();
  (void)find_layout(perturb(union_outline(first), 0.002, 0.0, 5U), first.formats, p, nullptr, nullptr, &all);
  CHECK(storage.pool.data() == pool_after);
  CHECK(storage.pool.capacity() == capacity);
}

TEST_CASE("box sides: position, direction, extent and the strip beyond") {
  std::vector<BoxSide> sides;
  for_each_box_side(Rect{1.0, 2.0, 1.4, 2.3}, 0.01, [&](const BoxSide& s) { sides.push_back(s); });
  REQUIRE(sides.size() == 4);
  CHECK(sides[0].vertical);
  CHECK(sides[0].pos == Approx(1.0));
  CHECK(sides[0].out == -1.0);
  CHECK(sides[0].lo == Approx(2.01));
  CHECK(sides[0].hi == Approx(2.29));
  CHECK(sides[0].beyond0 == Approx(0.97));
  CHECK(sides[0].beyond1 == Approx(0.99));
  CHECK(sides[3].vertical == false);
  CHECK(sides[3].pos == Approx(2.3));
  const Rect beyond = sides[3].beyond(1.1, 1.2);
  CHECK(beyond.x0 == Approx(1.1));
  CHECK(beyond.y0 == Approx(2.31));
  CHECK(beyond.y1 == Approx(2.33));
  // A side no longer than twice the margin is skipped.
  std::size_t n = 0;
  for_each_box_side(Rect{0, 0, 0.015, 0.5}, 0.01, [&](const BoxSide&) { ++n; });
  CHECK(n == 2);
}

TEST_CASE("footprint moves: a box split into two of the recipe, two merged into one") {
  const std::vector<BoxFormat> formats{{0.4, 0.3, "A"}, {0.3, 0.2, "B"}};
  const std::vector<FrameBox> one{{{0.0, 0.0, 0.4, 0.3}, 0, true}};
  const auto split = footprint_moves(one, formats, 0.01);
  REQUIRE(split.size() == 1);
  REQUIRE(split[0].add.size() == 2);
  CHECK(split[0].add[0].format == 1);
  CHECK(split[0].add[0].rect.x1 == Approx(0.2));
  const auto merge = footprint_moves(split[0].add, formats, 0.01);
  bool merged = false;
  for (const auto& m : merge) merged = merged || (m.remove.size() == 2 && m.add.size() == 1 && m.add[0].format == 0);
  CHECK(merged);
  // One format that tiles nothing else: no move.
  CHECK(footprint_moves(one, {{0.4, 0.3, "A"}}, 0.01).empty());
}

TEST_CASE("footprint moves: two boxes a gap apart may be one carton built over its format") {
  // Two 300 x 200 turned (200 along x) standing 15 mm apart: one 400 x 300 carton 3.75 % over
  // its format would fill them and the gap. The move spans both; 30 mm apart is no carton.
  const std::vector<BoxFormat> formats{{0.4, 0.3, "A"}, {0.3, 0.2, "B"}};
  auto pair = [](double gap_m) {
    return std::vector<FrameBox>{{{0.0, 0.0, 0.2, 0.3}, 1, false},
                                 {{0.2 + gap_m, 0.0, 0.4 + gap_m, 0.3}, 1, false}};
  };
  auto merges = [&](const std::vector<FrameBox>& boxes) {
    std::vector<FootprintMove> out;
    for (auto& m : footprint_moves(boxes, formats, 0.01))
      if (m.remove.size() == 2) out.push_back(m);
    return out;
  };
  const auto near = merges(pair(0.015));
  REQUIRE(near.size() == 1);
  REQUIRE(near[0].add.size() == 1);
  CHECK(near[0].add[0].format == 0);
  CHECK(near[0].add[0].rect.x0 == Approx(0.0));
  CHECK(near[0].add[0].rect.x1 == Approx(0.415));
  CHECK(merges(pair(0.035)).empty());
}

TEST_CASE("mixed formats: a seam decides for two boxes, the tape for one, a box without either is in doubt") {
  const KnownLayout l = mixed_rows();
  const auto outline = union_outline(l);
  LayoutParams p;
  p.search.time_budget_ms = 60000.0;
  const LayoutResult plain = find_layout(outline, l.formats, p, nullptr);
  REQUIRE(plain.status == DetectionStatus::kOk);
  CHECK(plain.ambiguous);  // the outline cannot tell

  // Seams alone: where two boxes stand their seam shows; where one stands, no seam is seen, and
  // a gap pressed shut looks the same. The best guess is right, and it is flagged.
  const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
  const LayoutResult untaped = find_layout(outline, l.formats, p, &seams);
  REQUIRE(untaped.status == DetectionStatus::kOk);
  CHECK(untaped.ambiguous);
  CHECK(match_error(truth_boxes(l), untaped.boxes) >= 0.0);
  // The tape along each carton's middle shows where one carton stands.
  const SeamEvidence with_tape = taped(seams, l);
  const LayoutResult a = find_layout(outline, l.formats, p, &with_tape);
  REQUIRE(a.status == DetectionStatus::kOk);
  CHECK_FALSE(a.ambiguous);
  CHECK(match_error(truth_boxes(l), a.boxes) >= 0.0);
  CHECK(match_error(truth_boxes(l), a.boxes) < 0.005);

  // The same outline with the other choice in every footprint is found just as well.
  KnownLayout swapped = l;
  swapped.boxes = {{0.0, 0.0, 1, false}, {0.2, 0.0, 1, false}, {0.4, 0.0, 0, true}, {0.8, 0.0, 1, false},
                   {1.0, 0.0, 1, false}, {0.0, 0.3, 0, true}, {0.4, 0.3, 1, false}, {0.6, 0.3, 1, false},
                   {0.8, 0.3, 0, true}};
  const SeamEvidence seams2 = taped(synthetic_seams(swapped, 0.003, 0.002), swapped);
  const LayoutResult b = find_layout(outline, l.formats, p, &seams2);
  REQUIRE(b.status == DetectionStatus::kOk);
  CHECK_FALSE(b.ambiguous);
  CHECK(match_error(truth_boxes(swapped), b.boxes) >= 0.0);
}

TEST_CASE("mixed formats: a seam missing along an axis without reference seams is a tie") {
  // 600 x 800: two 600 x 400 (A) stacked, or four 400 x 300 (B, turned) in two by two.
  const std::vector<BoxFormat> formats{{0.6, 0.4, "A"}, {0.4, 0.3, "B"}};
  KnownLayout four{"four B", formats, {{0.0, 0.0, 1, false}, {0.3, 0.0, 1, false}, {0.0, 0.4, 1, false},
                                        {0.3, 0.4, 1, false}}, 0.2, Eigen::Vector2d::Zero(), 0.0};
  KnownLayout two{"two A", formats, {{0.0, 0.0, 0, true}, {0.0, 0.4, 0, true}}, 0.2, Eigen::Vector2d::Zero(), 0.0};
  const auto outline = union_outline(four);
  LayoutParams p;
  p.search.time_budget_ms = 60000.0;
  // Both seams visible: the four boxes.
  const SeamEvidence both = synthetic_seams(four, 0.003, 0.002);
  const LayoutResult a = find_layout(outline, formats, p, &both);
  REQUIRE(a.status == DetectionStatus::kOk);
  CHECK_FALSE(a.ambiguous);
  CHECK(match_error(truth_boxes(four), a.boxes) >= 0.0);
  // Only the seam across the middle: the vertical seams may be pressed shut (no vertical seam
  // anywhere to compare with), so the layer is flagged, whichever layout is returned.
  const SeamEvidence middle = synthetic_seams(two, 0.003, 0.002);
  const LayoutResult b = find_layout(outline, formats, p, &middle);
  REQUIRE(b.status == DetectionStatus::kOk);
  CHECK(b.ambiguous);
}

TEST_CASE("seam likelihood: a missing seam weighs at most half of a clear one") {
  // Row of 400 x 300 (A) and turned 300 x 200 (B) boxes, axis-aligned: A A | B B | A A, all
  // seams open. A split of an A into two Bs predicts a seam that is not there; merging the two
  // Bs into an A misses one that is. Both pieces of evidence run 300 mm; gaps can be pressed
  // shut, so the first must count for less (at most half) than the second.
  const std::vector<BoxFormat> formats{{0.4, 0.3, "A"}, {0.3, 0.2, "B"}};
  KnownLayout l{"row", formats, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  l.boxes = {{0.0, 0.0, 0, true}, {0.4, 0.0, 0, true}, {0.8, 0.0, 1, false},
             {1.0, 0.0, 1, false}, {1.2, 0.0, 0, true}, {1.6, 0.0, 0, true}};
  const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
  const auto outline = union_outline(l);
  REQUIRE(outline.size() == 1);
  auto fb = [](double x0, double x1, int format, bool along_x) {
    return FrameBox{Rect{x0, 0.0, x1, 0.3}, format, along_x};
  };
  const std::vector<FrameBox> truth{fb(0.0, 0.4, 0, true), fb(0.4, 0.8, 0, true), fb(0.8, 1.0, 1, false),
                                    fb(1.0, 1.2, 1, false), fb(1.2, 1.6, 0, true), fb(1.6, 2.0, 0, true)};
  std::vector<FrameBox> split = truth;  // the first A as two Bs: a seam at x = 0.2 not seen
  split[0] = fb(0.0, 0.2, 1, false);
  split.insert(split.begin() + 1, fb(0.2, 0.4, 1, false));
  std::vector<FrameBox> merged = truth;  // the two Bs as one A: the seam at x = 1.0 missed
  merged[2] = fb(0.8, 1.2, 0, true);
  merged.erase(merged.begin() + 3);
  SeamLikelihood lik(seams, LayoutFrame{}, outline.front(), 0.01, 0.012, kNoCap);
  REQUIRE(lik.calibrate({&truth, &split, &merged}));
  const double against_missing = lik.compare(truth, split);  // split predicts the missing seam
  const double for_present = lik.compare(truth, merged);     // truth predicts the present seam
  INFO("missing " << against_missing << " present " << for_present);
  CHECK(for_present > SeamLikelihood::decisive_nats(0.2));
  CHECK(against_missing > 0.0);
  CHECK(against_missing <= 0.55 * for_present);
  // Capped below what decides, absent seams alone never decide; a present one still does.
  SeamLikelihood capped(seams, LayoutFrame{}, outline.front(), 0.01, 0.012, 0.5 * SeamLikelihood::decisive_nats(0.2));
  REQUIRE(capped.calibrate({&truth, &split, &merged}));
  CHECK(capped.compare(truth, split) == Approx(0.5 * SeamLikelihood::decisive_nats(0.2)));
  CHECK(capped.compare(truth, merged) == Approx(for_present));
}

TEST_CASE("seam likelihood: candidates sharing no seam calibrate on the strongest of their seams") {
  // A lone pinwheel and its mirror image share no interior seam: the reference comes from the
  // strongest half of both candidates' pieces, and the seams of the true one decide.
  for (bool mirrored : {false, true}) {
    const KnownLayout l = pinwheel(0.4, 0.3, mirrored);
    const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
    const auto outline = union_outline(l);
    REQUIRE(outline.size() == 1);
    const std::vector<FrameBox> right = frame_boxes(l), other = frame_boxes(pinwheel(0.4, 0.3, !mirrored));
    SeamLikelihood lik(seams, LayoutFrame{}, outline.front(), 0.01, 0.012, kNoCap);
    REQUIRE(lik.calibrate({&right, &other}));
    CHECK(lik.compare(right, other) > SeamLikelihood::decisive_nats(0.3));
  }
}

TEST_CASE("seam likelihood: a faint trace on clean box tops decides nothing") {
  // Clean box tops are exactly 0 in the raster (its depth and dark-line parts start above a
  // noise threshold), so their spread is 0. Seams showing at 2 % of a full seam are no evidence
  // however clean the tops: measured, not usable (the layout is flagged). At 30 % they decide.
  const KnownLayout l = pinwheel(0.4, 0.3, false);
  const auto outline = union_outline(l);
  REQUIRE(outline.size() == 1);
  const std::vector<FrameBox> right = frame_boxes(l), other = frame_boxes(pinwheel(0.4, 0.3, true));
  for (const float scale : {0.02f, 0.3f}) {
    INFO("seams at " << scale << " of a full seam");
    SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
    for (float& v : seams.seam) v *= scale;
    SeamLikelihood lik(seams, LayoutFrame{}, outline.front(), 0.01, 0.012, kNoCap);
    const bool usable = lik.calibrate({&right, &other});
    CHECK(lik.measured());
    CHECK(usable == (scale > 0.1f));
    if (usable) CHECK(lik.compare(right, other) > SeamLikelihood::decisive_nats(0.3));
  }
}
