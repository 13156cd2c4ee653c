#include "pick_check_answer.hpp"

#include <algorithm>

#include "result_record.hpp"

namespace palletd {

namespace {

modbus::CheckResult check_result_of(PickVerdict verdict) {
  switch (verdict) {
    case PickVerdict::kPickOk:
      return modbus::CheckResult::kPickOk;
    case PickVerdict::kBoxStillThere:
      return modbus::CheckResult::kBoxStillThere;
    case PickVerdict::kExtraBoxGone:
      return modbus::CheckResult::kExtraBoxGone;
    case PickVerdict::kNeighbourMoved:
      return modbus::CheckResult::kNeighbourMoved;
    case PickVerdict::kFailed:
      break;
  }
  return modbus::CheckResult::kNone;
}

std::uint16_t count_u16(std::size_t n) { return static_cast<std::uint16_t>(std::min<std::size_t>(n, 65535)); }

/// Registers 135..139: the boxes gone, those moved, and the slot the largest move now has.
modbus::CheckRecord check_record(const PickCheck& check, const Detection& now) {
  modbus::CheckRecord r;
  r.result = check_result_of(check.verdict);
  std::size_t gone = 0, moved = 0;
  const BoxCheck* most = nullptr;
  for (const BoxCheck& c : check.boxes) {
    if (!c.present) ++gone;
    if (!c.moved) continue;
    ++moved;
    if (most == nullptr || c.shift_mm > most->shift_mm) most = &c;
  }
  r.boxes_gone = count_u16(gone);
  r.boxes_moved = count_u16(moved);
  if (most != nullptr) {
    r.largest_move_m = 1e-3 * most->shift_mm;
    for (std::size_t i = 0; i < now.boxes.size() && i < modbus::kMaxBoxes; ++i)
      if (now.boxes[i].center == most->now.center) r.moved_slot = count_u16(i + 1);
  }
  return r;
}

/// The groups the result block reports (all their boxes in the reported slots), in its order.
std::vector<const PickGroup*> reported_groups(const Detection& d) {
  const int slots = static_cast<int>(std::min<std::size_t>(d.boxes.size(), modbus::kMaxBoxes));
  std::vector<const PickGroup*> out;
  for (const PickGroup& g : d.groups) {
    if (g.boxes.empty()) continue;
    if (std::all_of(g.boxes.begin(), g.boxes.end(), [&](int b) { return b >= 0 && b < slots; }))
      out.push_back(&g);
  }
  return out;
}

}  // namespace

std::vector<int> picked_boxes(const Detection& last, std::uint16_t picked_box, std::uint16_t picked_group) {
  std::vector<int> out;
  const std::size_t slots = std::min<std::size_t>(last.boxes.size(), modbus::kMaxBoxes);
  if (picked_box > 0 && picked_box <= slots) out.push_back(picked_box - 1);
  const std::vector<const PickGroup*> groups = reported_groups(last);
  if (picked_group > 0 && picked_group <= groups.size())
    for (int b : groups[picked_group - 1u]->boxes)
      if (std::find(out.begin(), out.end(), b) == out.end()) out.push_back(b);
  return out;
}

CheckRefusal refuse_check(const ResultSnapshot* last, const std::vector<int>& picked,
                          const modbus::HandshakeEvent& event) {
  const auto refuse = [](modbus::PickCheckFailure why, const std::string& text) {
    return CheckRefusal{std::in_place, why, "pick check: " + text};
  };
  if (last == nullptr)
    return refuse(modbus::PickCheckFailure::kNoLayout, "there is no result to check against yet");
  if (last->error != modbus::ErrorCode::kNone)
    return refuse(modbus::PickCheckFailure::kNoLayout,
                  "the result in the block failed (" + last->error_text + ")");
  if (last->detection.status != DetectionStatus::kOk || last->detection.boxes.empty() || !last->frame)
    return refuse(modbus::PickCheckFailure::kNoLayout, "the result in the block has no boxes");
  if (picked.empty())
    return refuse(modbus::PickCheckFailure::kNothingPicked,
                  "registers 4 and 5 (" + std::to_string(event.picked_box) + ", " +
                      std::to_string(event.picked_group) +
                      ") name no box or group of the result in the block (" +
                      std::to_string(last->detection.boxes.size()) + " boxes, " +
                      std::to_string(last->detection.groups.size()) + " groups)");
  return std::nullopt;
}

CheckAnswer answer_pick_check(const ResultSnapshot& last, const Frame& after, const std::vector<int>& picked,
                              const Config& cfg) {
  CheckAnswer a;
  a.check = check_pick(*last.frame, last.detection, after, picked, cfg.check);
  if (a.check.verdict == PickVerdict::kFailed) {
    a.detection = last.detection;
    a.record.status = modbus::ResultStatus::kFailed;
    a.record.error = modbus::ErrorCode::kPickCheckFailed;
    a.record.error_detail = static_cast<std::uint16_t>(modbus::PickCheckFailure::kBadFrame);
    a.error_text = "pick check: " + a.check.message;
    return a;
  }
  a.detection = after_pick(last.detection, a.check, after, cfg.detection);
  a.record = to_result_record(a.detection, after.T_base_camera.has_value());
  a.record.check = check_record(a.check, a.detection);
  if (a.detection.boxes.empty()) a.record.detail = modbus::ResultDetail::kLayerPicked;
  auto total = a.check.timing_ms.find("total");
  a.record.processing_ms = total != a.check.timing_ms.end() ? total->second : 0.0;
  return a;
}

}  // namespace palletd
