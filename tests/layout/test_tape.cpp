// Tape along a carton's flaps as evidence between layouts (src/detection/layout/evidence/tape.hpp).
#include <cmath>
#include <limits>
#include <random>

#include <catch2/catch.hpp>

#include "evidence/seam_likelihood.hpp"
#include "evidence/tape.hpp"
#include "frame_boxes.hpp"
#include "layout_fixtures.hpp"
#include "layout_internal.hpp"

using namespace palletd;
using namespace palletd::layout_test;
using namespace palletd::layout_detail;

namespace {

constexpr double kTapeUncapped = std::numeric_limits<double>::infinity();
constexpr float kBoard = 1000.f;  ///< the board's intensity [counts]

/// Where a line of `width_m` runs along the middle of `box` (its long axis), offset by offset_m.
bool on_middle(const FrameBox& box, const Eigen::Vector2d& p, double width_m, double offset_m = 0.0) {
  const Rect& r = box.rect;
  if (p.x() < r.x0 || p.x() > r.x1 || p.y() < r.y0 || p.y() > r.y1) return false;
  const double across = box.long_along_x ? p.y() - 0.5 * (r.y0 + r.y1) : p.x() - 0.5 * (r.x0 + r.x1);
  return std::abs(across - offset_m) <= 0.5 * width_m;
}

/// The layout's seam raster with its tops' intensity: the board with noise of `noise` counts,
/// and `intensity` along a line of width_m on the middle of each box of `lined`.
SeamEvidence with_tops(const KnownLayout& layout, const std::vector<FrameBox>& lined, float intensity,
                       double width_m, float noise, double offset_m = 0.0) {
  SeamEvidence seams = synthetic_seams(layout, 0.003, 0.002);
  const std::size_t n = seams.seam.size();
  seams.tops.assign(n, 0.f);
  seams.tops_seen.assign(n, 0.f);
  std::mt19937 rng(7);
  std::normal_distribution<float> gauss(0.f, noise);
  const std::vector<FrameBox> boxes = frame_boxes(layout);
  for (int iy = 0; iy < seams.height; ++iy) {
    for (int ix = 0; ix < seams.width; ++ix) {
      const Eigen::Vector2d p = seams.origin_m + seams.cell_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      const auto c =
          static_cast<std::size_t>(iy) * static_cast<std::size_t>(seams.width) + static_cast<std::size_t>(ix);
      bool inside = false;
      for (const FrameBox& b : boxes) inside = inside || on_middle(b, p, 1e9);
      if (!inside) continue;
      bool line = false;
      for (const FrameBox& b : lined) line = line || on_middle(b, p, width_m, offset_m);
      seams.tops[c] = (line ? intensity : kBoard) + gauss(rng);
      seams.tops_seen[c] = 1.f;
    }
  }
  return seams;
}

}  // namespace

TEST_CASE("tape: a band along one carton's middle decides a pinwheel against its mirror image") {
  // Pressed cartons at a coarse pitch: no seam stands out of the tops (the seam raster is blank),
  // so the seams cannot decide. A 48 mm band along the first carton's middle, 30 % darker than
  // the board, runs across the mirror image's first carton: it decides, for either handedness.
  for (bool mirrored : {false, true}) {
    const KnownLayout l = pinwheel(0.4, 0.3, mirrored);
    const std::vector<FrameBox> right = frame_boxes(l), other = frame_boxes(pinwheel(0.4, 0.3, !mirrored));
    SeamEvidence seams = with_tops(l, {right.front()}, 0.7f * kBoard, 0.048, 20.f);
    std::fill(seams.seam.begin(), seams.seam.end(), 0.f);
    const auto outline = union_outline(l);
    REQUIRE(outline.size() == 1);
    SeamLikelihood lik(seams, LayoutFrame{}, outline.front(), 0.01, 0.012, kTapeUncapped);
    CHECK_FALSE(lik.calibrate({&right, &other}));
    REQUIRE(lik.reads_tape());
    CHECK(lik.compare(right, other) > SeamLikelihood::decisive_nats(0.3));
    CHECK(lik.compare(other, right) < -SeamLikelihood::decisive_nats(0.3));
  }
}

TEST_CASE("tape: noise, a seam-wide line and a band across a carton are no band along it") {
  const KnownLayout l = pinwheel(0.4, 0.3, false);
  const std::vector<FrameBox> right = frame_boxes(l), other = frame_boxes(pinwheel(0.4, 0.3, true));
  const auto outline = union_outline(l);
  REQUIRE(outline.size() == 1);
  SECTION("the board and its noise only") {
    const SeamEvidence seams = with_tops(l, {}, kBoard, 0.0, 40.f);
    const TapeEvidence tape(seams, LayoutFrame{}, -0.05, -0.05, 300, 300);
    for (const FrameBox& b : right) CHECK(tape.taped_length_m(b) == 0.0);
    CHECK(tape.compare_m(right, other) == 0.0);
  }
  SECTION("a dark line 6 mm wide on the middle (a flap gap, not tape)") {
    const SeamEvidence seams = with_tops(l, right, 0.5f * kBoard, 0.006, 10.f);
    const TapeEvidence tape(seams, LayoutFrame{}, -0.05, -0.05, 300, 300);
    for (const FrameBox& b : right) CHECK(tape.taped_length_m(b) == 0.0);
  }
  SECTION("a faint band (3 % of the board)") {
    const SeamEvidence seams = with_tops(l, right, 0.97f * kBoard, 0.048, 5.f);
    const TapeEvidence tape(seams, LayoutFrame{}, -0.05, -0.05, 300, 300);
    for (const FrameBox& b : right) CHECK(tape.taped_length_m(b) == 0.0);
  }
  SECTION("bands along the right layout's cartons are across the mirror's") {
    const SeamEvidence seams = with_tops(l, right, 1.3f * kBoard, 0.048, 20.f);
    const TapeEvidence tape(seams, LayoutFrame{}, -0.05, -0.05, 300, 300);
    for (const FrameBox& b : right) CHECK(tape.taped_length_m(b) == Approx(0.34).margin(0.021));
    for (const FrameBox& b : other) CHECK(tape.taped_length_m(b) == 0.0);
    CHECK(tape.compare_m(right, other) > 1.3);
  }
}

TEST_CASE("tape: a band a gap off the box's middle is found, and a turned box's band in the layer frame") {
  const KnownLayout l = block(2, 1, 0.6, 0.4);
  const std::vector<FrameBox> boxes = frame_boxes(l);
  // The search places boxes at their nominal size: the band may lie 15 mm off their middle.
  const SeamEvidence off = with_tops(l, boxes, 0.75f * kBoard, 0.048, 20.f, 0.015);
  const TapeEvidence tape(off, LayoutFrame{}, -0.05, -0.05, 450, 200);
  CHECK(tape.taped_length_m(boxes.front()) > 0.5);
  // taped() reads a box given in the layer frame, whatever its yaw.
  KnownLayout turned = l;
  turned.theta_rad = 0.5;
  turned.offset = Eigen::Vector2d(0.2, -0.1);
  const std::vector<Box2d> truth = truth_boxes(turned);
  SeamEvidence seams = synthetic_seams(turned, 0.003, 0.002);
  seams.tops.assign(seams.seam.size(), 0.f);
  seams.tops_seen.assign(seams.seam.size(), 0.f);
  for (int iy = 0; iy < seams.height; ++iy) {
    for (int ix = 0; ix < seams.width; ++ix) {
      const Eigen::Vector2d p = seams.origin_m + seams.cell_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      const Eigen::Vector2d q = Eigen::Rotation2Dd(-truth[0].yaw_rad) * (p - truth[0].center);
      if (std::abs(q.x()) > 0.3 || std::abs(q.y()) > 0.2) continue;
      const auto c =
          static_cast<std::size_t>(iy) * static_cast<std::size_t>(seams.width) + static_cast<std::size_t>(ix);
      seams.tops[c] = std::abs(q.y()) <= 0.024 ? 0.7f * kBoard : kBoard;
      seams.tops_seen[c] = 1.f;
    }
  }
  CHECK(taped(truth[0], seams));
  Box2d across = truth[0];  // the same place turned by 90 degrees: the band runs across it
  across.yaw_rad += M_PI / 2;
  across.long_m = 0.4;
  across.short_m = 0.3;
  CHECK_FALSE(taped(across, seams));
}

TEST_CASE("tape: a band the layout puts no carton's middle on is unexplained") {
  // Two 600 x 400 side by side, a band along the first one's middle. Their layout explains it;
  // a layout of 400 x 300 cartons across the same place (their middles run the other way) or
  // one shifted by half a carton's width does not.
  const KnownLayout l = block(2, 1, 0.6, 0.4);
  const std::vector<FrameBox> boxes = frame_boxes(l);
  const SeamEvidence seams = with_tops(l, {boxes.front()}, 0.7f * kBoard, 0.048, 20.f);
  const TapeEvidence tape(seams, LayoutFrame{}, -0.1, -0.1, 480, 200);
  CHECK(tape.unexplained_band_m(boxes) == 0.0);
  std::vector<FrameBox> across = boxes;  // the first carton's place as two 400 x 300 turned
  across.front() = {Rect{0.0, 0.0, 0.3, 0.4}, 0, false};
  across.insert(across.begin() + 1, FrameBox{Rect{0.3, 0.0, 0.6, 0.4}, 0, false});
  CHECK(tape.unexplained_band_m(across) > 0.4);
  std::vector<FrameBox> shifted = boxes;
  shifted.front().rect.y0 += 0.2;
  shifted.front().rect.y1 += 0.2;
  CHECK(tape.unexplained_band_m(shifted) > 0.4);
  // Without a band nothing is unexplained, whatever the layout.
  const TapeEvidence plain(with_tops(l, {}, kBoard, 0.0, 20.f), LayoutFrame{}, -0.1, -0.1, 480, 200);
  CHECK(plain.unexplained_band_m(across) == 0.0);
}

TEST_CASE("tape: two cartons under one box show a band across each half, one carton none") {
  // Two 600 x 400 side by side. Bands across the first along the middles of its halves (two
  // 400 x 300 cartons laid across it, each taped lengthwise): taped in halves. A band along its
  // middle (one carton), or across one half only, is not.
  const KnownLayout l = block(2, 1, 0.6, 0.4);
  const std::vector<FrameBox> boxes = frame_boxes(l);
  const Box2d first{Eigen::Vector2d(0.3, 0.2), 0.0, 0.6, 0.4, 0};
  const FrameBox left{Rect{0.0, 0.0, 0.3, 0.4}, 0, false}, right{Rect{0.3, 0.0, 0.6, 0.4}, 0, false};
  CHECK(taped_in_halves(first, with_tops(l, {left, right}, 0.7f * kBoard, 0.048, 20.f)));
  CHECK_FALSE(taped_in_halves(first, with_tops(l, {boxes.front()}, 0.7f * kBoard, 0.048, 20.f)));
  CHECK_FALSE(taped_in_halves(first, with_tops(l, {left}, 0.7f * kBoard, 0.048, 20.f)));
  CHECK_FALSE(taped_in_halves(first, with_tops(l, {}, kBoard, 0.0, 20.f)));
}

TEST_CASE("tape: a label beside a carton's middle is no band of a carton's tape") {
  // Two 600 x 400 side by side; a shipping label (150 x 100 mm, lighter than the board) on the
  // first, off its middle. With no carton's length given, its edges read as a band 120 mm long or
  // more that no box explains; a band counts only when it runs half the shortest carton, and the
  // label does not. A band of tape along the first carton's middle, which a layout of 400 x 300
  // across the place does not explain, runs the carton's length and still counts.
  const KnownLayout l = block(2, 1, 0.6, 0.4);
  const std::vector<FrameBox> boxes = frame_boxes(l);
  SeamEvidence seams = with_tops(l, {}, kBoard, 0.0, 20.f);
  for (int iy = 0; iy < seams.height; ++iy) {
    for (int ix = 0; ix < seams.width; ++ix) {
      const Eigen::Vector2d p = seams.origin_m + seams.cell_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      if (p.x() < 0.2 || p.x() > 0.35 || p.y() < 0.25 || p.y() > 0.35) continue;
      seams.tops[static_cast<std::size_t>(iy) * static_cast<std::size_t>(seams.width) +
                 static_cast<std::size_t>(ix)] = 1.6f * kBoard;
    }
  }
  const TapeEvidence labelled(seams, LayoutFrame{}, -0.1, -0.1, 480, 200);
  CHECK(labelled.unexplained_band_m(boxes) >= 0.12);
  CHECK(labelled.unexplained_band_m(boxes, 0.4) == 0.0);
  const TapeEvidence taped(with_tops(l, {boxes.front()}, 0.7f * kBoard, 0.048, 20.f), LayoutFrame{}, -0.1,
                           -0.1, 480, 200);
  std::vector<FrameBox> across = boxes;  // the first carton's place as two 400 x 300 turned
  across.front() = {Rect{0.0, 0.0, 0.3, 0.4}, 0, false};
  across.insert(across.begin() + 1, FrameBox{Rect{0.3, 0.0, 0.6, 0.4}, 0, false});
  CHECK(taped.unexplained_band_m(across, 0.4) > 0.4);
}

TEST_CASE("tape: a box's reading is kept for its exact place only") {
  // Layouts compared in pairs share most boxes, so each placement is read once. A box moved
  // across, or turned, is another placement: read where it now stands.
  const KnownLayout l = block(2, 1, 0.6, 0.4);
  const std::vector<FrameBox> boxes = frame_boxes(l);
  const SeamEvidence seams = with_tops(l, {boxes.front()}, 0.7f * kBoard, 0.048, 20.f);
  const TapeEvidence tape(seams, LayoutFrame{}, -0.1, -0.1, 480, 200);
  const std::vector<FrameBox> none;
  const double taped = tape.only_m({boxes.front()}, none);
  CHECK(taped > 0.5);
  CHECK(tape.only_m({boxes.front()}, none) == taped);  // read again from what was kept
  FrameBox off = boxes.front();                        // 150 mm across: the band runs outside its search
  off.rect.y0 += 0.15;
  off.rect.y1 += 0.15;
  CHECK(tape.only_m({off}, none) == 0.0);
  FrameBox turned = boxes.front();  // the same rectangle with its long side the other way
  turned.long_along_x = false;
  CHECK(tape.only_m({turned}, none) == 0.0);
  CHECK(tape.only_m({boxes.front(), off}, none) == taped);
  CHECK(tape.only_m({boxes.back()}, none) == 0.0);  // the second carton carries no band
}

TEST_CASE("tape: the boxes that show it are counted where no seam shows between them") {
  // Four 600 x 400 cartons pressed together (the seam raster blank), tape along three of them.
  const KnownLayout l = block(2, 2, 0.6, 0.4);
  const std::vector<FrameBox> boxes = frame_boxes(l);
  SeamEvidence seams = with_tops(l, {boxes[0], boxes[1], boxes[3]}, 0.7f * kBoard, 0.048, 20.f);
  std::fill(seams.seam.begin(), seams.seam.end(), 0.f);
  std::vector<LayoutBox> layout;
  for (const Box2d& b : truth_boxes(l)) {
    LayoutBox box;
    static_cast<Box2d&>(box) = b;
    layout.push_back(box);
  }
  const std::vector<PolygonWithHoles> outline = union_outline(l);
  const InteriorSeams pressed = measure_interior_seams(layout, seams, outline);
  CHECK(pressed.seen_share() < 0.1);
  CHECK(pressed.taped_boxes == 3);
  // Where the seams show, the tape is not asked for (the count costs a reading per box).
  std::fill(seams.seam.begin(), seams.seam.end(), 1.f);
  const InteriorSeams seen = measure_interior_seams(layout, seams, outline);
  CHECK(seen.seen_share() > 0.9);
  CHECK(seen.taped_boxes == 0);
}
