// evaluate_frame: which answers count as exact, and which as wrong answers the PLC acts on.
#include <catch2/catch.hpp>

#include "palletd/results/evaluation.hpp"

using namespace palletd;

namespace {

Truth cartons(int n) {
  Truth t;
  t.expect = "boxes";
  for (int i = 0; i < n; ++i) {
    TruthBox& b = t.boxes.emplace_back();
    b.center = Eigen::Vector3d(0.4 * i, 0.0, 1.5);
    b.long_axis = Eigen::Vector3d::UnitX();
    b.normal = -Eigen::Vector3d::UnitZ();
    b.long_m = 0.4;
    b.short_m = 0.3;
  }
  return t;
}

Detection answer(DetectionStatus status, const Truth& t, bool flagged = false) {
  Detection d;
  d.status = status;
  d.ambiguous = flagged;
  if (status != DetectionStatus::kOk) return d;
  d.boxes.reserve(t.boxes.size());  // no box moved (gcc 12 reads a moved optional as uninitialised)
  for (const TruthBox& b : t.boxes) {
    DetectedBox& db = d.boxes.emplace_back();
    db.center = b.center;
    db.long_axis = b.long_axis;
    db.format = 0;
  }
  return d;
}

}  // namespace

TEST_CASE("a sheet or an empty pallet answered where cartons stand is a wrong answer the PLC acts on",
          "[eval]") {
  const Truth three = cartons(3);
  const FrameEval right = evaluate_frame(answer(DetectionStatus::kOk, three), three, {});
  CHECK(right.exact);
  CHECK_FALSE(right.unflagged_wrong);

  for (const DetectionStatus s : {DetectionStatus::kSlipSheet, DetectionStatus::kEmpty}) {
    const FrameEval e = evaluate_frame(answer(s, three), three, {});
    CHECK_FALSE(e.exact);
    CHECK(e.unflagged_wrong);
  }
  // Answers that stop the cell are not acted on.
  for (const DetectionStatus s : {DetectionStatus::kNoLayout, DetectionStatus::kRecipeMismatch}) {
    CHECK_FALSE(evaluate_frame(answer(s, three), three, {}).unflagged_wrong);
  }
  // A layout flagged in doubt stops the cell too.
  Detection missing_one = answer(DetectionStatus::kOk, three, true);
  missing_one.boxes.pop_back();
  CHECK_FALSE(evaluate_frame(missing_one, three, {}).unflagged_wrong);
  missing_one.ambiguous = false;
  CHECK(evaluate_frame(missing_one, three, {}).unflagged_wrong);
}

TEST_CASE("boxes answered on a sheet are wrong, the sheet named is right", "[eval]") {
  Truth sheet;
  sheet.expect = "slip_sheet";
  const FrameEval named = evaluate_frame(answer(DetectionStatus::kSlipSheet, sheet), sheet, {});
  CHECK(named.exact);
  CHECK_FALSE(named.unflagged_wrong);
  Detection boxes = answer(DetectionStatus::kOk, cartons(2));
  const FrameEval on_sheet = evaluate_frame(boxes, sheet, {});
  CHECK_FALSE(on_sheet.exact);
  CHECK(on_sheet.unflagged_wrong);
  const FrameEval called_empty = evaluate_frame(answer(DetectionStatus::kEmpty, sheet), sheet, {});
  CHECK(called_empty.unflagged_wrong);
}
