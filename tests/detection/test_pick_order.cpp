// The configured pick order (sort_by_pick_order(), detection.hpp): far corner first, nearest
// first and rows, and the same order whichever way a few millimetres of pose noise tip boxes
// that stand symmetrically about the robot base.
#include <algorithm>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"

using namespace palletd;

namespace {

/// A box of 400 x 300 mm whose centre, in the base frame and the layer frame, is `x_m`, `y_m`;
/// its format is its number, so that an order can be read back.
DetectedBox box_at(double x_m, double y_m, int number, bool calibrated = true) {
  DetectedBox b;
  b.in_layer.center = Eigen::Vector2d(x_m, y_m);
  b.in_layer.long_m = b.long_m = 0.4;
  b.in_layer.short_m = b.short_m = 0.3;
  b.format = number;
  if (calibrated) b.base_position = Eigen::Vector3d(x_m, y_m, 1.0);
  return b;
}

std::vector<int> numbers_in_order(const std::vector<DetectedBox>& boxes) {
  std::vector<int> out;
  for (std::size_t k = 0; k < boxes.size(); ++k) {
    CHECK(boxes[k].pick_index == static_cast<int>(k));
    out.push_back(boxes[k].format);
  }
  return out;
}

/// A 2 x 2 block of boxes around the base origin, each centre moved by up to `noise_m`, listed in
/// a shuffled order.
std::vector<DetectedBox> noisy_block(std::mt19937& rng, double noise_m, bool calibrated) {
  std::uniform_real_distribution<double> noise(-noise_m, noise_m);
  std::vector<DetectedBox> boxes;
  int number = 0;
  for (const double x : {-0.2, 0.2})
    for (const double y : {-0.15, 0.15})
      boxes.push_back(box_at(x + noise(rng), y + noise(rng), number++, calibrated));
  std::shuffle(boxes.begin(), boxes.end(), rng);
  return boxes;
}

}  // namespace

TEST_CASE("pick order: far corner first puts the farthest box first and the nearest last") {
  std::vector<DetectedBox> boxes = {box_at(0.1, 0.0, 0), box_at(0.9, 0.2, 1), box_at(0.5, -0.1, 2)};
  sort_by_pick_order(boxes, PickOrder::kFarCornerFirst);
  CHECK(numbers_in_order(boxes) == std::vector<int>{1, 2, 0});
  sort_by_pick_order(boxes, PickOrder::kNearestFirst);
  CHECK(numbers_in_order(boxes) == std::vector<int>{0, 2, 1});
}

TEST_CASE("pick order: boxes symmetric about the base keep one order under millimetres of noise") {
  std::mt19937 rng(4242);
  for (const bool calibrated : {true, false}) {
    for (const PickOrder order :
         {PickOrder::kFarCornerFirst, PickOrder::kNearestFirst, PickOrder::kRowMajor}) {
      std::vector<DetectedBox> first = noisy_block(rng, 0.003, calibrated);
      sort_by_pick_order(first, order);
      const std::vector<int> expected = numbers_in_order(first);
      for (int trial = 0; trial < 50; ++trial) {
        std::vector<DetectedBox> boxes = noisy_block(rng, 0.003, calibrated);
        sort_by_pick_order(boxes, order);
        INFO("calibrated " << calibrated << " order " << static_cast<int>(order) << " trial " << trial);
        CHECK(numbers_in_order(boxes) == expected);
      }
    }
  }
}

TEST_CASE("pick order: tied distances go by x and then y") {
  // Four boxes at one distance from the base: the lower x first, at equal x the lower y.
  std::vector<DetectedBox> boxes = {box_at(0.3, 0.4, 0), box_at(-0.3, 0.4, 1), box_at(0.3, -0.4, 2),
                                    box_at(-0.3, -0.4, 3)};
  sort_by_pick_order(boxes, PickOrder::kFarCornerFirst);
  CHECK(numbers_in_order(boxes) == std::vector<int>{3, 1, 2, 0});
}

TEST_CASE("pick order: rows by x go along y within a row although their x scatters") {
  // Two rows at x = 0 and x = 0.4; within each row the x scatters by 8 mm, more than a tie.
  std::vector<DetectedBox> boxes = {box_at(0.008, 0.6, 0), box_at(0.0, 0.0, 1), box_at(0.405, 0.3, 2),
                                    box_at(-0.004, 0.3, 3), box_at(0.4, 0.0, 4)};
  sort_by_pick_order(boxes, PickOrder::kRowMajor);
  CHECK(numbers_in_order(boxes) == std::vector<int>{1, 3, 0, 4, 2});
}
