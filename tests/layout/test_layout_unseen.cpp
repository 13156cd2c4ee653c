// Boxes the outline cuts where the depth ends (find_layout with LayerSurroundings): completed when
// the view pins them down, never over a spot seen lower, flagged when their place is open.
#include <chrono>
#include <cmath>
#include <functional>

#include <catch2/catch.hpp>

#include "palletd/detection/layout.hpp"

#include "layout_fixtures.hpp"
#include "layout_internal.hpp"

using namespace palletd;
using namespace palletd::layout_test;

namespace {

constexpr double kTheta = 0.35;  // layout turned against the layer frame [rad]
const Eigen::Vector2d kOffset(0.2, -0.1);

Eigen::Vector2d to_layer(double x, double y) {
  return kOffset + Eigen::Vector2d(std::cos(kTheta) * x - std::sin(kTheta) * y,
                                   std::sin(kTheta) * x + std::cos(kTheta) * y);
}
Eigen::Vector2d to_layout(const Eigen::Vector2d& p) {
  const Eigen::Vector2d d = p - kOffset;
  return {std::cos(kTheta) * d.x() + std::sin(kTheta) * d.y(),
          -std::sin(kTheta) * d.x() + std::cos(kTheta) * d.y()};
}

PolygonWithHoles polygon(std::initializer_list<Eigen::Vector2d> layout_pts) {
  PolygonWithHoles p;
  for (const auto& q : layout_pts) p.outer.push_back(to_layer(q.x(), q.y()));
  return p;
}

/// Surroundings over [-1, 2] m squared, 5 mm cells, labelled by a function of the layout point.
LayerSurroundings surroundings(const std::function<std::uint8_t(const Eigen::Vector2d&)>& label_of) {
  LayerSurroundings s;
  s.origin_m = {-1.0, -1.0};
  s.cell_m = 0.005;
  s.width = s.height = 600;
  s.label.resize(600 * 600);
  for (int y = 0; y < s.height; ++y) {
    for (int x = 0; x < s.width; ++x) {
      const Eigen::Vector2d p = s.origin_m + s.cell_m * Eigen::Vector2d(x + 0.5, y + 0.5);
      s.label[static_cast<std::size_t>(y) * 600 + static_cast<std::size_t>(x)] = label_of(to_layout(p));
    }
  }
  return s;
}

// Two 400x300 boxes side by side (layout frame [0, 0.8] x [0, 0.3]); the depth ends beyond the
// oblique line x + 0.5 y = 0.72, so 61 % of the right box is seen.
bool beyond_cut(const Eigen::Vector2d& q) { return q.x() + 0.5 * q.y() > 0.72; }
bool on_layer(const Eigen::Vector2d& q) { return q.x() >= 0 && q.y() >= 0 && q.y() <= 0.3 && !beyond_cut(q); }

const std::vector<BoxFormat> kFormats{{0.4, 0.3, "400x300"}};

std::vector<Box2d> truth_pair() {
  std::vector<Box2d> t;
  for (double x0 : {0.0, 0.4}) {
    Box2d b;
    b.center = to_layer(x0 + 0.2, 0.15);
    b.yaw_rad = kTheta;
    b.long_m = 0.4;
    b.short_m = 0.3;
    b.format = 0;
    t.push_back(b);
  }
  return t;
}

}  // namespace

TEST_CASE(
    "a box the outline cuts where the depth ends is completed, pinned by its neighbour and the seen edges") {
  const std::vector<PolygonWithHoles> layer{polygon({{0, 0}, {0.72, 0}, {0.57, 0.3}, {0, 0.3}})};
  const LayerSurroundings unseen_beyond = surroundings([](const Eigen::Vector2d& q) -> std::uint8_t {
    if (on_layer(q)) return LayerSurroundings::kLevel;
    return beyond_cut(q) ? LayerSurroundings::kUnseen : LayerSurroundings::kBelow;
  });
  LayoutParams p;

  SECTION("depth ends beyond the cut: both boxes, the cut one flagged") {
    const LayoutResult r = find_layout(layer, kFormats, p, nullptr, &unseen_beyond);
    REQUIRE(r.status == DetectionStatus::kOk);
    REQUIRE(r.boxes.size() == 2);
    const double err = match_error(truth_pair(), r.boxes);
    CHECK(err >= 0.0);
    CHECK(err < 0.002);
    CHECK(r.completed_unseen == 1);
    REQUIRE(r.boxes.size() == 2);
    for (std::size_t i = 0; i < 2; ++i)
      CHECK(r.boxes[i].partly_unseen == (to_layout(r.boxes[i].center).x() > 0.4));
    CHECK_FALSE(r.ambiguous);
  }
  SECTION("the surface seen lower beyond the cut: the layer ends there, nothing is completed") {
    const LayerSurroundings seen_lower = surroundings([](const Eigen::Vector2d& q) -> std::uint8_t {
      return on_layer(q) ? LayerSurroundings::kLevel : LayerSurroundings::kBelow;
    });
    const LayoutResult r = find_layout(layer, kFormats, p, nullptr, &seen_lower);
    CHECK(r.completed_unseen == 0);
    for (const Box2d& b : r.boxes) CHECK(to_layout(b.center).x() < 0.4);
  }
  SECTION("without surroundings, or with completion off, the search alone decides") {
    const LayoutResult plain = find_layout(layer, kFormats, p, nullptr);
    CHECK(plain.completed_unseen == 0);
    CHECK(plain.boxes.size() < 2);
    p.completion.unseen_min_fraction = 0.0;
    const LayoutResult off = find_layout(layer, kFormats, p, nullptr, &unseen_beyond);
    CHECK(off.completed_unseen == 0);
    CHECK(off.boxes.size() == plain.boxes.size());
  }
  SECTION("less of the box seen than unseen_min_fraction: not completed") {
    p.completion.unseen_min_fraction = 0.65;  // 61 % is seen
    const LayoutResult r = find_layout(layer, kFormats, p, nullptr, &unseen_beyond);
    CHECK(r.completed_unseen == 0);
  }
}

TEST_CASE("completing boxes where the depth ends stops at the deadline and says so") {
  // The scene above, in its layout frame: the left box placed, the cut one to complete.
  const std::vector<PolygonWithHoles> layer{polygon({{0, 0}, {0.72, 0}, {0.57, 0.3}, {0, 0.3}})};
  const LayerSurroundings around = surroundings([](const Eigen::Vector2d& q) -> std::uint8_t {
    if (on_layer(q)) return LayerSurroundings::kLevel;
    return beyond_cut(q) ? LayerSurroundings::kUnseen : LayerSurroundings::kBelow;
  });
  layout_detail::LayoutFrame frame;
  frame.theta_rad = kTheta;
  frame.pivot = kOffset;
  const PolygonWithHoles in_frame = frame.to_frame(layer.front());
  const std::vector<layout_detail::FrameBox> left{{{0.0, 0.0, 0.4, 0.3}, 0, true}};
  const auto now = std::chrono::steady_clock::now();
  auto complete = [&](std::chrono::steady_clock::time_point end) {
    return layout_detail::complete_unseen(left, in_frame, in_frame, frame, kFormats, around, LayoutParams{},
                                          layout_detail::Deadline{end});
  };
  const layout_detail::UnseenCompletion in_time = complete(now + std::chrono::hours(1));
  CHECK_FALSE(in_time.timed_out);
  CHECK(in_time.added == 1);
  CHECK(in_time.boxes.size() == 2);
  const layout_detail::UnseenCompletion late = complete(now - std::chrono::seconds(1));
  CHECK(late.timed_out);
  CHECK(late.added == 0);
  CHECK(late.boxes.size() == 1);
}

TEST_CASE("a piece of a box with the depth ending on every side: its place is open, so it is flagged") {
  // 250 x 250 mm seen, nothing seen around it: a 400x300 box could lie several ways over it.
  const std::vector<PolygonWithHoles> layer{polygon({{0, 0}, {0.25, 0}, {0.25, 0.25}, {0, 0.25}})};
  const LayerSurroundings around = surroundings([](const Eigen::Vector2d& q) -> std::uint8_t {
    const bool in = q.x() >= 0 && q.y() >= 0 && q.x() <= 0.25 && q.y() <= 0.25;
    return in ? LayerSurroundings::kLevel : LayerSurroundings::kUnseen;
  });
  const LayoutResult r = find_layout(layer, kFormats, LayoutParams{}, nullptr, &around);
  INFO(r.reason);
  REQUIRE(r.completed_unseen == 1);
  CHECK(r.ambiguous);
}

TEST_CASE("a piece of the layer no box covers, larger than uncovered_flag_fraction of a box, flags the layout") {
  // Two 400x300 boxes and a 230 x 230 mm piece beside them (44 % of a box): the boxes are found,
  // the piece stays uncovered, the layout is in doubt there.
  const std::vector<PolygonWithHoles> layer{
      polygon({{0, 0}, {0.8, 0}, {0.8, 0.3}, {0.23, 0.3}, {0.23, 0.53}, {0, 0.53}})};
  LayoutParams p;
  const LayoutResult r = find_layout(layer, kFormats, p, nullptr);
  REQUIRE(r.status == DetectionStatus::kOk);
  CHECK(r.boxes.size() == 2);
  CHECK(r.ambiguous);
  p.completion.uncovered_flag_fraction = 0.6;  // the piece is smaller than that
  CHECK_FALSE(find_layout(layer, kFormats, p, nullptr).ambiguous);
  p.completion.uncovered_flag_fraction = 0.0;  // off
  CHECK_FALSE(find_layout(layer, kFormats, p, nullptr).ambiguous);
  // The two boxes alone: the gap-wide slivers of a perturbed outline flag nothing.
  const std::vector<PolygonWithHoles> pair{polygon({{0, 0}, {0.8, 0}, {0.8, 0.3}, {0, 0.3}})};
  CHECK_FALSE(find_layout(perturb(pair, 0.003, 0.008, 7U), kFormats, LayoutParams{}, nullptr).ambiguous);
}
