#include "palletd/results/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace palletd {

std::vector<int> assign_min_cost(const std::vector<std::vector<double>>& cost) {
  // Hungarian method with potentials (O(n^2 m)) on a rows <= cols matrix; transposed otherwise.
  const std::size_t rows = cost.size();
  const std::size_t cols = rows == 0 ? 0 : cost[0].size();
  if (rows == 0 || cols == 0) return std::vector<int>(rows, -1);
  if (rows > cols) {
    std::vector<std::vector<double>> t(cols, std::vector<double>(rows));
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t c = 0; c < cols; ++c) t[c][r] = cost[r][c];
    const std::vector<int> col_to_row = assign_min_cost(t);
    std::vector<int> out(rows, -1);
    for (std::size_t c = 0; c < cols; ++c)
      if (col_to_row[c] >= 0) out[static_cast<std::size_t>(col_to_row[c])] = static_cast<int>(c);
    return out;
  }
  const double inf = std::numeric_limits<double>::infinity();
  const std::size_t n = rows, m = cols;
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<std::size_t> p(m + 1, 0), way(m + 1, 0);
  for (std::size_t i = 1; i <= n; ++i) {
    p[0] = i;
    std::size_t j0 = 0;
    std::vector<double> minv(m + 1, inf);
    std::vector<bool> used(m + 1, false);
    do {
      used[j0] = true;
      const std::size_t i0 = p[j0];
      double delta = inf;
      std::size_t j1 = 0;
      for (std::size_t j = 1; j <= m; ++j) {
        if (used[j]) continue;
        const double cur = cost[i0 - 1][j - 1] - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (std::size_t j = 0; j <= m; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {
      const std::size_t j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  std::vector<int> out(n, -1);
  for (std::size_t j = 1; j <= m; ++j)
    if (p[j] != 0) out[p[j] - 1] = static_cast<int>(j - 1);
  return out;
}

double percentile(std::vector<double> values, double pct) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double pos = std::clamp(pct, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, values.size() - 1);
  const double t = pos - static_cast<double>(lo);
  return values[lo] * (1.0 - t) + values[hi] * t;
}

namespace {

// Angle between two undirected axes in the plane of `normal`, [deg] in [0, 90].
double axis_angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d n = normal.normalized();
  Eigen::Vector3d pa = a - a.dot(n) * n, pb = b - b.dot(n) * n;
  if (pa.norm() < 1e-12 || pb.norm() < 1e-12) return 90.0;
  pa.normalize();
  pb.normalize();
  const double c = std::min(1.0, std::abs(pa.dot(pb)));
  return std::acos(c) * 180.0 / M_PI;
}

}  // namespace

FrameEval evaluate_frame(const Detection& detection, const Truth& truth, const std::vector<std::string>& format_names,
                         const EvalOptions& options) {
  FrameEval e;
  e.status = to_string(detection.status);
  e.expect = truth.expect.empty() ? "boxes" : truth.expect;
  e.ambiguous = detection.ambiguous;
  if (detection.ambiguous) e.flag_reason = detection.ambiguity_reason;
  e.truth_boxes = truth.boxes.size();
  e.detected_boxes = detection.boxes.size();
  auto total = detection.timing_ms.find("total");
  e.runtime_ms = total != detection.timing_ms.end() ? total->second : 0.0;
  e.timing_ms = detection.timing_ms;

  const double big = 1e6;
  std::vector<std::vector<double>> cost(truth.boxes.size(), std::vector<double>(detection.boxes.size(), big));
  for (std::size_t t = 0; t < truth.boxes.size(); ++t) {
    const double gate = 0.25 * truth.boxes[t].short_m;
    for (std::size_t d = 0; d < detection.boxes.size(); ++d) {
      const double dist = (truth.boxes[t].center - detection.boxes[d].center).norm();
      if (dist <= gate) cost[t][d] = dist;
    }
  }
  const std::vector<int> match = assign_min_cost(cost);
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  bool within = true;
  e.layout_confidence = detection.layout_confidence;
  e.outline_unobserved = detection.outline_unobserved;
  for (const DetectedBox& db : detection.boxes) e.boxes.push_back({db.score, false, box_features(db.score_terms)});
  for (std::size_t t = 0; t < match.size(); ++t) {
    if (match[t] < 0 || cost[t][static_cast<std::size_t>(match[t])] >= big) continue;
    const auto d = static_cast<std::size_t>(match[t]);
    pairs.emplace_back(t, d);
    const TruthBox& tb = truth.boxes[t];
    const DetectedBox& db = detection.boxes[d];
    const double pos_mm = (tb.center - db.center).norm() * 1000.0;
    const double yaw_deg = axis_angle_deg(tb.long_axis, db.long_axis, tb.normal);
    e.position_errors_mm.push_back(pos_mm);
    e.yaw_errors_deg.push_back(yaw_deg);
    const bool close = pos_mm <= options.exact_position_mm && yaw_deg <= options.exact_yaw_deg;
    if (!close) within = false;
    const auto f = static_cast<std::size_t>(db.format);
    bool format_right = !(f < format_names.size() && !format_names[f].empty() && format_names[f] != tb.format);
    if (db.format < 0) {  // a size measured on the frame (size-range recipe) against the carton's
      const double size_mm = 1e3 * std::max(std::abs(db.long_m - tb.long_m), std::abs(db.short_m - tb.short_m));
      e.size_errors_mm.push_back(size_mm);
      format_right = size_mm <= options.measured_size_mm;
    }
    if (!format_right) e.formats_right = false;
    e.boxes[d].right = close && format_right && e.expect == "boxes";
  }
  e.matched = pairs.size();
  double pw_sum = 0.0;
  std::size_t pw_n = 0;
  for (std::size_t a = 0; a < pairs.size(); ++a) {
    for (std::size_t b = a + 1; b < pairs.size(); ++b) {
      const double dt = (truth.boxes[pairs[a].first].center - truth.boxes[pairs[b].first].center).norm();
      const double dd = (detection.boxes[pairs[a].second].center - detection.boxes[pairs[b].second].center).norm();
      pw_sum += std::abs(dt - dd) * 1000.0;
      ++pw_n;
    }
  }
  e.pairwise_error_mm = pw_n > 0 ? pw_sum / static_cast<double>(pw_n) : 0.0;
  e.recipe_wrong = options.recipe_wrong;
  e.best_recipe = detection.recipe_check.best_recipe;
  if (e.recipe_wrong && e.expect == "boxes") {
    e.exact = detection.status == DetectionStatus::kRecipeMismatch;
  } else {
    e.exact = e.expect == "boxes" ? detection.status == DetectionStatus::kOk && e.matched == e.truth_boxes &&
                                         e.matched == e.detected_boxes && within && e.formats_right
                                   : e.status == e.expect;
  }
  // The PLC acts on boxes, on an empty pallet and on a sheet to take off; recipe_mismatch and
  // no_layout stop the cell.
  const bool acted_on = detection.status == DetectionStatus::kOk ||
                        detection.status == DetectionStatus::kEmpty ||
                        detection.status == DetectionStatus::kSlipSheet;
  e.unflagged_wrong = !e.exact && acted_on && !detection.ambiguous;
  return e;
}

bool recipe_matches(const std::vector<BoxFormat>& formats, const Truth& truth) {
  if (formats.size() != truth.recipe_mm.size()) return false;
  std::vector<bool> used(formats.size(), false);
  for (const auto& mm : truth.recipe_mm) {
    bool found = false;
    for (std::size_t i = 0; i < formats.size() && !found; ++i) {
      if (used[i] || std::abs(1e3 * formats[i].long_m - mm[0]) > 1.0 || std::abs(1e3 * formats[i].short_m - mm[1]) > 1.0)
        continue;
      used[i] = true;
      found = true;
    }
    if (!found) return false;
  }
  return true;
}

EvalSummary summarize(const std::vector<FrameEval>& frames) {
  EvalSummary s;
  std::vector<double> pos, yaw, sizes, runtime, pairwise;
  for (const auto& f : frames) {
    ++s.frames;
    if (f.status == "ok") ++s.ok_frames;
    if (f.exact) ++s.exact_frames;
    if (f.ambiguous) ++s.ambiguous_frames;
    if (f.unflagged_wrong) ++s.unflagged_wrong;
    const bool mismatch = f.status == to_string(DetectionStatus::kRecipeMismatch);
    if (f.recipe_wrong && f.expect == "boxes") {
      ++s.wrong_recipe_frames;
      if (mismatch) ++s.wrong_recipe_mismatch;
      if (f.best_recipe) ++s.wrong_recipe_named;
      if (f.best_recipe && f.best_recipe == f.truth_recipe) ++s.wrong_recipe_named_right;
    } else if (mismatch) {
      ++s.false_mismatch;
    }
    if (f.expect == "empty") {
      ++s.empty_frames;
      if (f.exact) ++s.empty_right;
    } else if (f.expect == "slip_sheet") {
      ++s.sheet_frames;
      if (f.exact) ++s.sheet_right;
    }
    s.truth_boxes += f.truth_boxes;
    s.detected_boxes += f.detected_boxes;
    s.matched += f.matched;
    pos.insert(pos.end(), f.position_errors_mm.begin(), f.position_errors_mm.end());
    yaw.insert(yaw.end(), f.yaw_errors_deg.begin(), f.yaw_errors_deg.end());
    sizes.insert(sizes.end(), f.size_errors_mm.begin(), f.size_errors_mm.end());
    runtime.push_back(f.runtime_ms);
    if (f.matched >= 2) pairwise.push_back(f.pairwise_error_mm);
    if (f.outline_tied == 0) {
      ++s.unambiguous_frames;
      if (f.exact) ++s.unambiguous_exact;
      if (f.ambiguous) ++s.unambiguous_flagged;
    } else if (f.outline_tied == 1) {
      ++s.tied_frames;
      if (f.exact) {
        ++s.tied_resolved;
      } else if (f.ambiguous) {
        ++s.tied_flagged;
      } else {
        ++s.tied_wrong;
      }
    }
  }
  s.unambiguous_exact_rate = s.unambiguous_frames > 0 ? static_cast<double>(s.unambiguous_exact) /
                                                            static_cast<double>(s.unambiguous_frames)
                                                      : 0.0;
  s.precision = s.detected_boxes > 0 ? static_cast<double>(s.matched) / static_cast<double>(s.detected_boxes) : 0.0;
  s.recall = s.truth_boxes > 0 ? static_cast<double>(s.matched) / static_cast<double>(s.truth_boxes) : 0.0;
  s.exact_rate = s.frames > 0 ? static_cast<double>(s.exact_frames) / static_cast<double>(s.frames) : 0.0;
  s.position_median_mm = percentile(pos, 50);
  s.position_p95_mm = percentile(pos, 95);
  s.position_max_mm = pos.empty() ? 0.0 : *std::max_element(pos.begin(), pos.end());
  s.yaw_median_deg = percentile(yaw, 50);
  s.yaw_p95_deg = percentile(yaw, 95);
  s.size_measured = sizes.size();
  s.size_median_mm = percentile(sizes, 50);
  s.size_p95_mm = percentile(sizes, 95);
  double pw = 0.0;
  for (double v : pairwise) pw += v;
  s.pairwise_mean_mm = pairwise.empty() ? 0.0 : pw / static_cast<double>(pairwise.size());
  s.runtime_median_ms = percentile(runtime, 50);
  s.runtime_p95_ms = percentile(runtime, 95);
  return s;
}

}  // namespace palletd
