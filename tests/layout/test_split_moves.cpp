// A box of the recipe laid over two smaller cartons and their gaps: split by the seam that shows
// across it (rank_layouts.hpp settle_footprint_moves, seam_likelihood.hpp split_moves).
#include <catch2/catch.hpp>

#include "evidence/rank_layouts.hpp"
#include "evidence/seam_likelihood.hpp"
#include "frame_boxes.hpp"
#include "layout_fixtures.hpp"
#include "layout_internal.hpp"

using namespace palletd;
using namespace palletd::layout_test;
using namespace palletd::layout_detail;

namespace {

const std::vector<BoxFormat> kSplitFormats{{0.315, 0.232, "315x232"}, {0.5, 0.35, "500x350"}};
constexpr double kGap_m = 0.006;  ///< between the cartons
/// Where the two cartons of a column meet: the middle of the 500 x 350 laid over them [m].
constexpr double kMiddle_y = 0.232 + kGap_m / 2;
constexpr double kMergeTol_m = 0.014;

/// Two columns of two 315 x 232 cartons, kGap_m apart; `left_one_box`: the left column is one
/// 500 x 350 carton instead (long side along y, centred on where the two would stand).
KnownLayout columns(bool left_one_box) {
  KnownLayout l{"columns", kSplitFormats, {}, 0.0, Eigen::Vector2d::Zero(), 0.0};
  double right_x = 0.315 + kGap_m;
  const double upper_y = 0.232 + kGap_m;
  if (left_one_box) {
    l.boxes.push_back({0.1575 - 0.175, kMiddle_y - 0.25, 1, false});
    right_x += 0.0175;  // beside the wider carton
  } else {
    l.boxes.push_back({0.0, 0.0, 0, true});
    l.boxes.push_back({0.0, upper_y, 0, true});
  }
  l.boxes.push_back({right_x, 0.0, 0, true});
  l.boxes.push_back({right_x, upper_y, 0, true});
  return l;
}

/// The layout the outline prefers: the 500 x 350 over the left column, the right column's two.
std::vector<FrameBox> big_box_left() {
  const double right_x = 0.315 + kGap_m, upper_y = 0.232 + kGap_m;
  return {{{0.1575 - 0.175, kMiddle_y - 0.25, 0.1575 + 0.175, kMiddle_y + 0.25}, 1, false},
          {{right_x, 0.0, right_x + 0.315, 0.232}, 0, true},
          {{right_x, upper_y, right_x + 0.315, upper_y + 0.232}, 0, true}};
}

/// The layer as the camera's mask has it: one rectangle, the narrow gaps included.
PolygonWithHoles layer_rectangle() {
  PolygonWithHoles p;
  const double x1 = 0.6475 + kGap_m, y1 = 0.464 + kGap_m;
  p.outer = {{-0.006, -0.006}, {x1 + 0.006, -0.006}, {x1 + 0.006, y1 + 0.006}, {-0.006, y1 + 0.006}};
  return p;
}

/// settle_footprint_moves on `boxes` with the seams of `truth`; the boxes it leaves.
std::vector<FrameBox> settled(const KnownLayout& truth, const std::vector<FrameBox>& boxes, bool* tied) {
  const SeamEvidence seams = synthetic_seams(truth, 0.003, 0.005);  // the 6 mm gaps show as seams
  ComponentFrames frames;
  frames.add(LayoutFrame{}, layer_rectangle());
  Candidate best{LayoutFrame{}, boxes, 0.0, 0};
  SeamJudge judge;
  judge.seams = &seams;
  judge.min_short_m = 0.232;
  judge.merge_tol_m = kMergeTol_m;
  judge.absent_cap_nats = 0.9 * SeamLikelihood::decisive_nats(judge.min_short_m);
  *tied = settle_footprint_moves(best, {best}, {0}, frames, kSplitFormats, judge, LayoutParams{});
  return best.boxes;
}

}  // namespace

TEST_CASE("split moves: the two cartons a larger box of the recipe covers with their gaps") {
  const std::vector<FrameBox> boxes = big_box_left();
  const std::vector<FootprintMove> moves = split_moves(boxes, kSplitFormats, kMergeTol_m, 0.054);
  REQUIRE_FALSE(moves.empty());
  for (const FootprintMove& m : moves) {
    CHECK(m.remove == std::vector<std::size_t>{0});  // only the 500 x 350 holds two cartons
    REQUIRE(m.add.size() == 2);
    for (const FrameBox& b : m.add) {
      CHECK(b.format == 0);
      CHECK(b.rect.x0 >= boxes[0].rect.x0 - 1e-9);  // within the box it replaces
      CHECK(b.rect.x1 <= boxes[0].rect.x1 + 1e-9);
    }
    // Stacked along the 500 mm side: the split runs across the box, never along its middle.
    CHECK(m.add[0].rect.y1 <= m.add[1].rect.y0 + 1e-9);
  }
  // A slack smaller than what the box has to spare: no split.
  CHECK(split_moves(boxes, kSplitFormats, kMergeTol_m, 0.02).empty());
  // Two cartons side by side along a box's long middle (where the flaps' tape runs): no split.
  const std::vector<BoxFormat> halves{{0.6, 0.4, "600x400"}, {0.6, 0.19, "600x190"}};
  CHECK(split_moves({{{0.0, 0.0, 0.6, 0.4}, 0, true}}, halves, kMergeTol_m, 0.054).empty());
}

TEST_CASE("a box laid over two cartons gives way to them where their seam shows across it") {
  bool tied = true;
  const std::vector<FrameBox> two = settled(columns(false), big_box_left(), &tied);
  CHECK_FALSE(tied);
  REQUIRE(two.size() == 4);
  const std::vector<FrameBox> truth = frame_boxes(columns(false));
  for (const FrameBox& t : truth) {
    bool found = false;
    for (const FrameBox& b : two)
      found = found || (b.format == t.format && std::abs(b.rect.x0 - t.rect.x0) < 0.02 &&
                        std::abs(b.rect.y0 - t.rect.y0) < 0.02 && std::abs(b.rect.y1 - t.rect.y1) < 0.02);
    CHECK(found);
  }
  // Where one 500 x 350 carton stands, no seam crosses it: it stays, and no tie is left.
  const std::vector<FrameBox> laid = frame_boxes(columns(true));
  const std::vector<FrameBox> one = settled(columns(true), laid, &tied);
  CHECK_FALSE(tied);
  REQUIRE(one.size() == 3);
  CHECK(one.front().format == 1);
  CHECK(one.front().rect.x1 == Approx(laid.front().rect.x1));
}
