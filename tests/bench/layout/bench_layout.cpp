// Layout search benchmark: best-first search time for layers of 4..40 boxes (200 x 150 on
// 1200 x 1000, full and partial), other patterns, the area methods, and the paper mode's time as
// a ratio with its cap. Prints markdown tables for docs/benchmarks.md.
//
//   palletd_bench_layout [--reps N] [--paper-cap N] [--paper-budget-ms MS]
//   palletd_bench_layout --unseen [--reps N]   # only the completion table
#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "layout_fixtures.hpp"
#include "palletd/detection/layout.hpp"

using namespace palletd;
using namespace palletd::layout_test;

namespace {

struct Run {
  double median_ms = 0, max_ms = 0;
  double cpu_median_ms = 0;  ///< thread CPU time: robust on a shared machine
  LayoutResult last;
};

double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

Run time_it(const std::vector<PolygonWithHoles>& outline, const std::vector<BoxFormat>& formats,
            const LayoutParams& p, const SeamEvidence* seams, int reps) {
  Run r;
  std::vector<double> ms, cpu;
  for (int i = 0; i < reps; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = cpu_ms();
    r.last = find_layout(outline, formats, p, seams);
    cpu.push_back(cpu_ms() - c0);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  std::sort(cpu.begin(), cpu.end());
  r.cpu_median_ms = cpu[cpu.size() / 2];
  r.median_ms = ms[ms.size() / 2];
  r.max_ms = ms.back();
  return r;
}

const char* verdict(const KnownLayout& l, const LayoutResult& r) {
  if (r.status != DetectionStatus::kOk) return "no_layout";
  const bool exact = match_error(truth_boxes(l), r.boxes) >= 0.0;
  if (r.ambiguous) return exact ? "exact, ambiguous" : "ambiguous";
  return exact ? "exact" : "WRONG";
}

/// A 40-box layer whose right column is cut where the depth ends: find_layout without and with
/// the surroundings (completion).
void bench_unseen(const LayoutParams& best_first, int reps) {
std::printf("\n## Completion where the depth ends, 40-box layer (cut by a line 20 deg off its axis, seams given)\n\n");
std::printf("| surroundings | median [ms] | CPU [ms] | boxes | completed | result |\n|---|---|---|---|---|---|\n");
{
  KnownLayout l = grid_200x150(40);
  l.theta_rad = 0.15;
  const std::vector<PolygonWithHoles> full = union_outline(l);
  const Eigen::Vector2d u(std::cos(l.theta_rad), std::sin(l.theta_rad)), v(-u.y(), u.x());
  double umax = -1e9, vmin = 1e9;
  for (const auto& q : full.front().outer) {
    umax = std::max(umax, q.dot(u));
    vmin = std::min(vmin, q.dot(v));
  }
  // Beyond the cut (f > 0) the depth ends, 20 deg off the layout's axis, from 60 mm off the
  // bottom right box upwards.
  const double slope = std::tan(20.0 * M_PI / 180.0);
  const auto f = [&](const Eigen::Vector2d& q) { return q.dot(u) + slope * (q.dot(v) - vmin) - (umax - 0.06); };
  PolygonWithHoles cut;
  const Ring2d& ring = full.front().outer;
  for (std::size_t i = 0; i < ring.size(); ++i) {  // Sutherland-Hodgman against f <= 0
    const Eigen::Vector2d a = ring[i], b = ring[(i + 1) % ring.size()];
    const double fa = f(a), fb = f(b);
    if (fa <= 0) cut.outer.push_back(a);
    if ((fa <= 0) != (fb <= 0)) cut.outer.push_back(a + (b - a) * (fa / (fa - fb)));
  }
  const auto inside = [&](const Eigen::Vector2d& q) {
    bool in = false;
    for (std::size_t i = 0, j = cut.outer.size() - 1; i < cut.outer.size(); j = i++) {
      const Eigen::Vector2d& a = cut.outer[i];
      const Eigen::Vector2d& b = cut.outer[j];
      if ((a.y() > q.y()) != (b.y() > q.y()) && q.x() < (b.x() - a.x()) * (q.y() - a.y()) / (b.y() - a.y()) + a.x())
        in = !in;
    }
    return in;
  };
  LayerSurroundings around;
  around.cell_m = 0.005;
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const auto& q : ring) {
    x0 = std::min(x0, q.x()); y0 = std::min(y0, q.y()); x1 = std::max(x1, q.x()); y1 = std::max(y1, q.y());
  }
  around.origin_m = {x0 - 0.3, y0 - 0.3};
  around.width = static_cast<int>((x1 - x0 + 0.6) / around.cell_m);
  around.height = static_cast<int>((y1 - y0 + 0.6) / around.cell_m);
  around.label.resize(static_cast<std::size_t>(around.width) * static_cast<std::size_t>(around.height));
  for (int iy = 0; iy < around.height; ++iy) {
    for (int ix = 0; ix < around.width; ++ix) {
      const Eigen::Vector2d q = around.origin_m + around.cell_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      around.label[static_cast<std::size_t>(iy) * static_cast<std::size_t>(around.width) + static_cast<std::size_t>(ix)] =
          inside(q) ? LayerSurroundings::kLevel : f(q) > 0 ? LayerSurroundings::kUnseen : LayerSurroundings::kBelow;
    }
  }
  const std::vector<PolygonWithHoles> outline{cut};
  // The outline alone ties many layouts of this layer: the seams choose (as in the tables above).
  const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
  for (bool with : {false, true}) {
    std::vector<double> ms, cpu;
    LayoutResult last;
    for (int i = 0; i < reps; ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = cpu_ms();
      last = find_layout(outline, l.formats, best_first, &seams, with ? &around : nullptr);
      cpu.push_back(cpu_ms() - c0);
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(ms.begin(), ms.end());
    std::sort(cpu.begin(), cpu.end());
    // Truth boxes found within 15 mm (those the cut leaves 40 % or more of are the target).
    std::size_t found = 0;
    for (const Box2d& t : truth_boxes(l)) {
      for (const Box2d& b : last.boxes) found += (b.center - t.center).norm() < 0.015 ? 1 : 0;
    }
    std::printf("| %s | %.2f | %.2f | %zu | %zu | %zu of 40 truth boxes within 15 mm%s |\n", with ? "yes" : "no",
                ms[ms.size() / 2], cpu[cpu.size() / 2], last.boxes.size(), last.completed_unseen, found,
                last.ambiguous ? ", ambiguous" : "");
    if (std::getenv("BENCH_DBG")) {
      for (const Box2d& b : last.boxes) std::fprintf(stderr, "box %.3f %.3f yaw %.2f\n", b.center.dot(u), b.center.dot(v), b.yaw_rad);
    }
  }
}
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core: OpenCV would otherwise spread the raster work over threads
  int reps = 21;
  std::size_t paper_cap = 200000;
  double paper_budget_ms = 10000;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--reps") == 0) reps = std::max(1, std::atoi(argv[i + 1]));
    if (std::strcmp(argv[i], "--paper-cap") == 0) paper_cap = static_cast<std::size_t>(std::atol(argv[i + 1]));
    if (std::strcmp(argv[i], "--paper-budget-ms") == 0) paper_budget_ms = std::atof(argv[i + 1]);
  }
  if (argc >= 2 && std::strcmp(argv[1], "--unseen") == 0) {  // only the completion table
    LayoutParams p;
    p.search.time_budget_ms = 1000;
    bench_unseen(p, reps);
    return 0;
  }
  if (argc == 2 && std::strcmp(argv[1], "--profile") == 0) {  // one case in a loop, for perf
    KnownLayout l = grid_200x150(40);
    l.theta_rad = 0.15;
    const auto outline = perturb(union_outline(l), 0.002, 0.006, 11U);
    const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
    LayoutParams p;
    const Run r = time_it(outline, l.formats, p, &seams, 200);
    std::printf("median %.2f ms, cpu %.2f ms\n", r.median_ms, r.cpu_median_ms);
    return 0;
  }
  LayoutParams best_first;
  best_first.search.time_budget_ms = 1000;  // generous: we measure how long it needs
  best_first.search.outline_tolerance_m = 0.0015;  // half a pitch of the synthetic seam raster, as solve_layout sets it
  LayoutParams paper = best_first;
  paper.search.mode = SearchMode::kPaper;
  paper.search.paper_max_hypotheses = paper_cap;
  paper.search.time_budget_ms = paper_budget_ms;

  std::printf("## Layout search, 200 x 150 boxes on 1200 x 1000 (full at 40, partial below)\n\n");
  std::printf("| boxes | outline | seams | best_first median [ms] | CPU median [ms] | max [ms] | nodes | expansions | result | paper [ms] | paper hypotheses | paper cap hit | paper/best_first | paper result |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int n : {4, 8, 12, 16, 24, 32, 40}) {
    KnownLayout l = grid_200x150(n);
    l.theta_rad = 0.15;
    for (int variant = 0; variant < 3; ++variant) {
      const bool noisy = variant == 2;
      const bool with_seams = variant != 1;
      auto outline = union_outline(l);
      if (noisy) outline = perturb(outline, 0.002, 0.006, 11U);
      const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
      const SeamEvidence* sp = with_seams ? &seams : nullptr;
      const Run pr = time_it(outline, l.formats, best_first, sp, reps);
      std::string paper_cells = "| - | - | - | - | - ";
      if (variant == 1) {  // the paper scores the outline only
        const Run pp = time_it(outline, l.formats, paper, nullptr, 1);
        char buf[256];
        std::snprintf(buf, sizeof buf, "| %.1f | %zu | %s | %s%.0f | %s ", pp.median_ms, pp.last.hypotheses_visited,
                      pp.last.budget_exhausted ? "yes" : "no", pp.last.budget_exhausted ? ">= " : "",
                      pp.median_ms / std::max(pr.median_ms, 1e-3), verdict(l, pp.last));
        paper_cells = buf;
      }
      std::printf("| %d | %s | %s | %.2f | %.2f | %.2f | %zu | %zu | %s %s|\n", n, noisy ? "noisy +/-2 mm, rounded" : "ideal",
                  with_seams ? "yes" : "no", pr.median_ms, pr.cpu_median_ms, pr.max_ms, pr.last.hypotheses_visited,
                  pr.last.search_expansions, verdict(l, pr.last), paper_cells.c_str());
    }
  }

  std::printf("\n## Other patterns (ideal outline, synthetic seams / none)\n\n");
  std::printf("| layout | boxes | seams | median [ms] | CPU [ms] | nodes | expansions | result |\n|---|---|---|---|---|---|---|---|\n");
  for (KnownLayout l : {block(3, 3, 0.4, 0.3), brick(), pinwheel(0.4, 0.3, false), mixed_formats(), l_shaped(), clusters()}) {
    l.theta_rad = 0.3;
    const auto outline = union_outline(l);
    const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
    for (bool ws : {true, false}) {
      const Run r = time_it(outline, l.formats, best_first, ws ? &seams : nullptr, reps);
      std::printf("| %s | %zu | %s | %.2f | %.2f | %zu | %zu | %s |\n", l.name.c_str(), l.boxes.size(), ws ? "yes" : "no",
                  r.median_ms, r.cpu_median_ms, r.last.hypotheses_visited, r.last.search_expansions, verdict(l, r.last));
    }
  }

  std::printf("\n## Area(B ∩ C) methods, 40-box layer (noisy outline)\n\n");
  std::printf("| method | seams | median [ms] | CPU [ms] | result |\n|---|---|---|---|---|\n");
  {
    KnownLayout l = grid_200x150(40);
    l.theta_rad = 0.15;
    const auto outline = perturb(union_outline(l), 0.002, 0.006, 11U);
    const SeamEvidence seams = synthetic_seams(l, 0.003, 0.002);
    const std::pair<AreaMethod, const char*> methods[] = {
        {AreaMethod::kGridSat, "grid_sat (exact cells + SAT)"}, {AreaMethod::kRaster, "raster 3 mm + SAT"},
        {AreaMethod::kClip, "clip every query"}};
    for (bool ws : {false, true}) {
      for (const auto& [m, name] : methods) {
        LayoutParams p = best_first;
        p.search.area_method = m;
        const Run r = time_it(outline, l.formats, p, ws ? &seams : nullptr, reps);
        std::printf("| %s | %s | %.2f | %.2f | %s |\n", name, ws ? "yes" : "no", r.median_ms, r.cpu_median_ms,
                    verdict(l, r.last));
      }
    }
  }
  bench_unseen(best_first, reps);
  return 0;
}
