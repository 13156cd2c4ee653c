// Layout search benchmark: product search time for layers of 4..40 boxes (200 x 150 on
// 1200 x 1000, full and partial), other patterns, the area methods, and the paper mode's time as
// a ratio with its cap. Prints markdown tables for docs/benchmarks.md.
//
//   palletd_bench_layout [--reps N] [--paper-cap N] [--paper-budget-ms MS]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "layout_fixtures.hpp"
#include "palletd/layout.hpp"

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
  if (r.status != DetectionStatus::ok) return "no_layout";
  const bool exact = match_error(truth_boxes(l), r.boxes) >= 0.0;
  if (r.ambiguous) return exact ? "exact, ambiguous" : "ambiguous";
  return exact ? "exact" : "WRONG";
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
  LayoutParams product;
  product.time_budget_ms = 1000;  // generous: we measure how long it needs
  LayoutParams paper = product;
  paper.search = SearchMode::paper;
  paper.paper_max_hypotheses = paper_cap;
  paper.time_budget_ms = paper_budget_ms;

  std::printf("## Layout search, 200 x 150 boxes on 1200 x 1000 (full at 40, partial below)\n\n");
  std::printf("| boxes | outline | seams | product median [ms] | CPU median [ms] | max [ms] | nodes | expansions | result | paper [ms] | paper hypotheses | paper cap hit | paper/product | paper result |\n");
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
      const Run pr = time_it(outline, l.formats, product, sp, reps);
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
      const Run r = time_it(outline, l.formats, product, ws ? &seams : nullptr, reps);
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
        {AreaMethod::grid_sat, "grid_sat (exact cells + SAT)"}, {AreaMethod::raster, "raster 3 mm + SAT"},
        {AreaMethod::clip, "clip every query"}};
    for (bool ws : {false, true}) {
      for (const auto& [m, name] : methods) {
        LayoutParams p = product;
        p.area_method = m;
        const Run r = time_it(outline, l.formats, p, ws ? &seams : nullptr, reps);
        std::printf("| %s | %s | %.2f | %.2f | %s |\n", name, ws ? "yes" : "no", r.median_ms, r.cpu_median_ms,
                    verdict(l, r.last));
      }
    }
  }
  return 0;
}
