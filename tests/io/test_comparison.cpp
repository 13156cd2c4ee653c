// compare_detections: what palletctl compare reports between two results of one frame.
#include <catch2/catch.hpp>

#include "palletd/results/comparison.hpp"

using namespace palletd;

namespace {

Detection layer(int boxes) {
  Detection d;
  d.status = DetectionStatus::kOk;
  for (int i = 0; i < boxes; ++i) d.boxes.emplace_back().center = Eigen::Vector3d(0.4 * i, 0.0, 1.5);
  return d;
}

}  // namespace

TEST_CASE("equal results compare equal, a box moved beyond the limit is counted", "[compare]") {
  const Detection a = layer(4);
  CHECK_FALSE(compare_detections(a, a, 5.0).any());
  CHECK(compare_detections(a, a, 5.0).describe(a, a) == "same");

  Detection b = a;
  b.boxes[2].center.x() += 0.012;  // 12 mm
  const DetectionDifference moved = compare_detections(a, b, 5.0);
  CHECK(moved.any());
  CHECK(moved.boxes_moved == 1);
  CHECK(moved.max_move_mm == Approx(12.0));
  CHECK(moved.describe(a, b) == "1 box(es) moved (max 12.0 mm)");
  CHECK_FALSE(compare_detections(a, b, 15.0).any());  // within the limit

  // Listed in another order, the boxes still pair with their own.
  Detection shuffled = a;
  std::swap(shuffled.boxes[0], shuffled.boxes[3]);
  CHECK_FALSE(compare_detections(a, shuffled, 1.0).any());
}

TEST_CASE("status, box count, formats and the ambiguous flag are differences", "[compare]") {
  const Detection a = layer(3);
  Detection empty;
  empty.status = DetectionStatus::kEmpty;
  const DetectionDifference d = compare_detections(a, empty, 5.0);
  CHECK(d.status_differs);
  CHECK(d.count_differs);
  CHECK(d.describe(a, empty) == "status ok -> empty; boxes 3 -> 0");

  Detection fewer = layer(2);
  CHECK(compare_detections(a, fewer, 5.0).count_differs);
  CHECK(compare_detections(a, fewer, 5.0).boxes_moved == 0);  // the two left are where they were

  Detection other_format = a;
  other_format.boxes[1].format = 1;
  CHECK(compare_detections(a, other_format, 5.0).format_differs);

  Detection flagged = a;
  flagged.ambiguous = true;
  const DetectionDifference f = compare_detections(a, flagged, 5.0);
  CHECK(f.ambiguous_differs);
  CHECK(f.describe(a, flagged) == "ambiguous no -> yes");
}
