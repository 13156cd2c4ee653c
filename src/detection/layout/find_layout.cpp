// find_layout(): input checks, components, layout frames, search dispatch, per-box scores.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "layout_internal.hpp"
#include "layout_scoring.hpp"

namespace palletd {

using namespace layout_detail;

namespace {

constexpr double kSimplify_m = 0.004;  ///< outline simplification for corners and lines [m]

std::string check_formats(const std::vector<BoxFormat>& formats) {
  if (formats.empty()) return "the recipe lists no box format";
  for (std::size_t i = 0; i < formats.size(); ++i) {
    const auto& f = formats[i];
    if (!std::isfinite(f.long_m) || !std::isfinite(f.short_m) || f.long_m <= 0.0 || f.short_m <= 0.0) {
      std::ostringstream s;
      s << "box format " << i << " (" << f.name << ") has a zero, negative or invalid size";
      return s.str();
    }
    if (f.short_m > f.long_m + 1e-9) {
      std::ostringstream s;
      s << "box format " << i << " (" << f.name << ") lists its short side first";
      return s.str();
    }
  }
  return {};
}

Eigen::Vector2d centroid_of(const Ring2d& ring) {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const auto& p : ring) c += p;
  return ring.empty() ? c : Eigen::Vector2d(c / static_cast<double>(ring.size()));
}

struct Candidate {
  LayoutFrame frame;
  std::vector<FrameBox> boxes;
  double score = 0.0;
  std::size_t orientation = 0;
};

}  // namespace

LayoutResult find_layout(const std::vector<PolygonWithHoles>& components,
                         const std::vector<BoxFormat>& formats, const LayoutParams& params,
                         const SeamEvidence* seams) {
  const auto t0 = std::chrono::steady_clock::now();
  LayoutResult result;
  auto finish = [&]() {
    result.search_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return result;
  };
  if (std::string bad = check_formats(formats); !bad.empty()) {
    result.reason = bad;
    return finish();
  }
  if (components.empty()) {
    result.reason = "the layer has no outline";
    return finish();
  }
  double min_box_area = 1e9, min_short = 1e9;
  for (const auto& f : formats) {
    min_box_area = std::min(min_box_area, f.long_m * f.short_m);
    min_short = std::min(min_short, f.short_m);
  }
  const double min_edge = std::max(0.02, 0.25 * min_short);
  const auto budget = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double, std::milli>(std::max(0.0, params.time_budget_ms)));
  const auto end = t0 + budget;

  double total_area = 0.0, covered = 0.0;
  std::vector<std::string> reasons;
  for (std::size_t ci = 0; ci < components.size(); ++ci) {
    const PolygonWithHoles& comp = components[ci];
    const PolygonWithHoles comp_edges = simplified(comp, kSimplify_m);
    const double comp_area = area(comp);
    total_area += comp_area;
    if (comp.outer.size() < 3 || !(comp_area > 0.0)) {
      reasons.push_back("component " + std::to_string(ci) + " has no area");
      continue;
    }
    if (comp_area < params.a_min_fraction * min_box_area) {
      reasons.push_back("component " + std::to_string(ci) + " is smaller than every box format");
      continue;
    }
    // Share what is left of the budget among the components still to solve.
    const auto now = std::chrono::steady_clock::now();
    const auto left = end > now ? end - now : std::chrono::steady_clock::duration::zero();
    const Deadline deadline{now + left / static_cast<long>(components.size() - ci)};

    if (params.search == SearchMode::paper) {
      const PaperSolution ps = search_paper(comp, comp_edges, formats, params, deadline);
      result.hypotheses_visited += ps.visited;
      result.budget_exhausted = result.budget_exhausted || ps.cap_hit;
      if (!ps.found) {
        reasons.push_back("component " + std::to_string(ci) +
                          (orthogonal_corners(comp_edges, params.corner_angle_tol_deg, min_edge).empty()
                               ? " has no orthogonal corner (round or damaged outline)"
                               : ": no box of the recipe fits its outline"));
        continue;
      }
      result.score += ps.score;
      for (const auto& b : ps.boxes) {
        result.boxes.push_back(b);
        result.box_component.push_back(static_cast<int>(ci));
        const BoxSupport s = box_support(b, comp, nullptr, params);
        result.box_scores.push_back(s.score);
        covered += s.inside_area_m2;
      }
      continue;
    }

    const std::vector<double> thetas = layout_orientations(comp_edges, params.corner_angle_tol_deg, min_edge);
    if (thetas.empty()) {
      reasons.push_back("component " + std::to_string(ci) + " has no orthogonal corner (round or damaged outline)");
      continue;
    }
    std::vector<Candidate> cands;
    std::vector<SeamTable> tables;
    std::vector<PolygonWithHoles> frame_polys;
    std::string why;
    const std::size_t n_orient = std::min<std::size_t>(thetas.size(), 3);
    for (std::size_t oi = 0; oi < n_orient; ++oi) {
      const auto now2 = std::chrono::steady_clock::now();
      const auto left2 = deadline.end > now2 ? deadline.end - now2 : std::chrono::steady_clock::duration::zero();
      // The best supported orientation gets most of the component's share.
      const Deadline d2{now2 + (oi + 1 == n_orient ? left2 : left2 * 3 / 4)};
      LayoutFrame frame;
      frame.theta_rad = thetas[oi];
      frame.pivot = centroid_of(comp.outer);
      const PolygonWithHoles fp = frame.to_frame(comp);
      const PolygonWithHoles fe = frame.to_frame(comp_edges);
      Rect bounds{1e300, 1e300, -1e300, -1e300};
      for (const auto& p : fp.outer) {
        bounds.x0 = std::min(bounds.x0, p.x()); bounds.x1 = std::max(bounds.x1, p.x());
        bounds.y0 = std::min(bounds.y0, p.y()); bounds.y1 = std::max(bounds.y1, p.y());
      }
      SeamTable table;
      if (seams != nullptr && !seams->empty()) table = SeamTable(*seams, frame, bounds);
      const ComponentSolution cs = search_product(fp, fe, formats, params, table.empty() ? nullptr : &table, d2);
      const std::size_t slot = tables.size();
      tables.push_back(std::move(table));
      frame_polys.push_back(fp);
      result.hypotheses_visited += cs.visited;
      result.budget_exhausted = result.budget_exhausted || cs.budget_exhausted;
      if (!cs.found) {
        why = cs.reason;
        continue;
      }
      cands.push_back({frame, cs.boxes, cs.score, slot});
      if (cs.has_runner_up) cands.push_back({frame, cs.runner_up, cs.runner_up_score, slot});
    }
    if (cands.empty()) {
      reasons.push_back("component " + std::to_string(ci) + ": " + (why.empty() ? "no layout found" : why));
      continue;
    }
    std::stable_sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
    const Candidate& best = cands.front();
    result.score += best.score;
    // Runner-up: the best candidate that is materially different.
    const double same_tol = 0.25 * std::sqrt(min_box_area);
    for (std::size_t k = 1; k < cands.size(); ++k) {
      const Candidate& c = cands[k];
      const bool same_frame = std::abs(c.frame.theta_rad - best.frame.theta_rad) < 1e-9;
      if (same_frame && same_layout(c.boxes, best.boxes, same_tol)) continue;
      const double gap = best.score - c.score;
      if (result.runner_up_gap < 0 || gap < result.runner_up_gap) {
        result.runner_up_gap = gap;
        result.runner_up.clear();
        for (const auto& b : c.boxes) result.runner_up.push_back(c.frame.to_layer(b, formats));
      }
      if (gap < params.ambiguity_margin * min_box_area) result.ambiguous = true;
      break;
    }
    double comp_covered = 0;
    std::vector<BoxSupport> support;
    for (const auto& fb : best.boxes) {
      const SeamTable& t = tables[best.orientation];
      const bool use_seams = seams != nullptr && seams->strength > 0.0 && !t.empty();
      support.push_back(box_support(best.frame.to_layer(fb, formats), best.frame, frame_polys[best.orientation],
                                    use_seams ? &t : nullptr, params));
      comp_covered += support.back().inside_area_m2;
    }
    if (comp_covered < params.min_coverage * comp_area) {
      reasons.push_back("component " + std::to_string(ci) + ": boxes of the recipe cover only " +
                        std::to_string(static_cast<int>(100.0 * comp_covered / comp_area)) +
                        "% of it (its boxes match no recipe format)");
      continue;
    }
    covered += comp_covered;
    for (std::size_t k = 0; k < best.boxes.size(); ++k) {
      result.boxes.push_back(best.frame.to_layer(best.boxes[k], formats));
      result.box_component.push_back(static_cast<int>(ci));
      result.box_scores.push_back(support[k].score);
    }
  }
  result.coverage = total_area > 0 ? std::min(1.0, covered / total_area) : 0.0;
  if (result.boxes.empty()) {
    result.status = DetectionStatus::no_layout;
    std::string r;
    for (const auto& s : reasons) r += (r.empty() ? "" : "; ") + s;
    result.reason = r.empty() ? "no layout found" : r;
  } else {
    result.status = DetectionStatus::ok;
    std::string r;
    for (const auto& s : reasons) r += (r.empty() ? "" : "; ") + s;
    result.reason = r;
  }
  return finish();
}

}  // namespace palletd
