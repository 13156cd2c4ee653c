// palletctl eval: detection on every frame of a folder scored against its truth file.
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "detect_common.hpp"
#include "palletd/detection/detection.hpp"
#include "palletd/results/confidence_eval.hpp"
#include "palletd/results/evaluation.hpp"
#include "palletd/frames/frame_io.hpp"
#include "palletd/detection/layout.hpp"

namespace palletd {

namespace {

struct EvalArgs {
  std::vector<std::string> boxes;
  std::string config;
  int recipe = 0;
  bool json = false;
  bool quiet = false;
  bool cell_files = false;
  std::vector<std::string> dirs;
};

/// The parameters for one frame: with --cell-files, STEM.roi.yaml beside it (if there is one)
/// sets the region of interest and the pallet. Throws ConfigError on a bad file.
DetectionParams frame_params(const DetectionParams& base, const std::string& stem, bool cell_files) {
  DetectionParams params = base;
  if (!cell_files || !std::filesystem::exists(stem + ".roi.yaml")) return params;
  const CellFile cell = load_cell_file(stem + ".roi.yaml");
  if (cell.roi) params.roi = cell.roi;
  if (cell.pallet.top_z_m) params.pallet = cell.pallet;
  return params;
}

/// Whether the truth's layout is the only one its own outline supports: the truth boxes are drawn
/// in their layer (gaps between neighbours bridged), the outline traced, and the best-first search
/// run on that outline alone (no seams). 1 = another layout fits as well (or better), 0 = the
/// outline determines the truth, -1 = not checked.
int truth_outline_tied(const Truth& truth, const std::vector<BoxFormat>& formats, const std::vector<std::string>& names) {
  if (truth.boxes.empty() || formats.empty()) return -1;
  const TruthBox& b0 = truth.boxes.front();
  const Eigen::Vector3d n = b0.normal.normalized();
  Eigen::Vector3d e1 = b0.long_axis - b0.long_axis.dot(n) * n;
  if (e1.norm() < 1e-9) return -1;
  e1.normalize();
  const Eigen::Vector3d e2 = n.cross(e1);
  struct Rect2 {
    double x0, y0, x1, y1;
  };
  std::vector<Rect2> rects;
  std::vector<Box2d> boxes;
  double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
  for (const TruthBox& tb : truth.boxes) {
    const Eigen::Vector3d c = tb.center - b0.center;
    const Eigen::Vector2d u(tb.long_axis.dot(e1), tb.long_axis.dot(e2));
    const bool along_x = std::abs(u.x()) >= std::abs(u.y());
    const double hx = (along_x ? tb.long_m : tb.short_m) / 2, hy = (along_x ? tb.short_m : tb.long_m) / 2;
    const double x = c.dot(e1), y = c.dot(e2);
    rects.push_back({x - hx, y - hy, x + hx, y + hy});
    bx0 = std::min(bx0, x - hx); bx1 = std::max(bx1, x + hx);
    by0 = std::min(by0, y - hy); by1 = std::max(by1, y + hy);
    Box2d b;
    b.center = {x, y};
    b.yaw_rad = std::atan2(u.y(), u.x());
    b.long_m = tb.long_m;
    b.short_m = tb.short_m;
    b.format = -1;
    for (std::size_t i = 0; i < formats.size(); ++i) {
      const bool by_name = i < names.size() && !names[i].empty() && names[i] == tb.format;
      const bool by_size = std::abs(formats[i].long_m - tb.long_m) < 0.005 && std::abs(formats[i].short_m - tb.short_m) < 0.005;
      if (by_name || (b.format < 0 && by_size)) b.format = static_cast<int>(i);
    }
    boxes.push_back(b);
  }
  // Raster in the layout's own frame (boxes axis-aligned); gaps up to 2 * bridge are closed.
  const double cell = 0.002, bridge = 0.008, pad = 0.05;
  const int w = static_cast<int>((bx1 - bx0 + 2 * pad) / cell) + 1, h = static_cast<int>((by1 - by0 + 2 * pad) / cell) + 1;
  if (w <= 0 || h <= 0 || static_cast<double>(w) * h > 2.5e7) return -1;
  cv::Mat mask = cv::Mat::zeros(h, w, CV_8U);
  auto px = [&](double x) { return static_cast<int>(std::lround((x - bx0 + pad) / cell)); };
  auto py = [&](double y) { return static_cast<int>(std::lround((y - by0 + pad) / cell)); };
  for (const auto& r : rects) {
    cv::rectangle(mask, cv::Point(px(r.x0 - bridge), py(r.y0 - bridge)), cv::Point(px(r.x1 + bridge) - 1, py(r.y1 + bridge) - 1),
                  cv::Scalar(255), cv::FILLED);
  }
  const int k = static_cast<int>(std::lround(bridge / cell));
  cv::erode(mask, mask, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * k + 1, 2 * k + 1)));
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(mask, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_SIMPLE);
  auto ring_of = [&](const std::vector<cv::Point>& c) {
    Ring2d ring;
    for (const auto& p : c) ring.emplace_back(bx0 - pad + (p.x + 0.5) * cell, by0 - pad + (p.y + 0.5) * cell);
    return ring;
  };
  std::vector<PolygonWithHoles> polys;
  for (std::size_t i = 0; i < contours.size(); ++i) {
    if (hierarchy[i][3] >= 0) continue;
    PolygonWithHoles poly;
    poly.outer = ring_of(contours[i]);
    for (int c = hierarchy[i][2]; c >= 0; c = hierarchy[static_cast<std::size_t>(c)][0]) {
      poly.holes.push_back(ring_of(contours[static_cast<std::size_t>(c)]));
    }
    polys.push_back(std::move(poly));
  }
  LayoutParams p;
  p.search.time_budget_ms = 1000.0;
  const LayoutResult r = find_layout(polys, formats, p, nullptr);
  if (r.status != DetectionStatus::kOk || r.ambiguous || r.boxes.size() != boxes.size()) return 1;
  std::vector<bool> used(r.boxes.size(), false);
  for (const Box2d& t : boxes) {
    bool hit = false;
    for (std::size_t j = 0; j < r.boxes.size() && !hit; ++j) {
      if (used[j] || r.boxes[j].format != t.format || (r.boxes[j].center - t.center).norm() > 0.25 * t.short_m) continue;
      const double dyaw = std::abs(std::remainder(r.boxes[j].yaw_rad - t.yaw_rad, M_PI));
      if (dyaw > M_PI / 4) continue;
      used[j] = true;
      hit = true;
    }
    if (!hit) return 1;
  }
  return 0;
}

nlohmann::json boxes_json(const std::vector<BoxEval>& boxes) {
  nlohmann::json out = nlohmann::json::array();
  for (const BoxEval& b : boxes) out.push_back({{"score", b.score}, {"right", b.right}, {"features", b.features}});
  return out;
}

nlohmann::json to_json(const FrameEval& f) {
  return {{"frame", f.frame},
          {"status", f.status},
          {"ambiguous", f.ambiguous},
          {"flag_reason", f.flag_reason},
          {"truth_boxes", f.truth_boxes},
          {"detected_boxes", f.detected_boxes},
          {"matched", f.matched},
          {"position_error_mm", f.position_errors_mm},
          {"yaw_error_deg", f.yaw_errors_deg},
          {"pairwise_error_mm", f.pairwise_error_mm},
          {"formats_right", f.formats_right},
          {"expect", f.expect},
          {"exact", f.exact},
          {"unflagged_wrong", f.unflagged_wrong},
          {"outline_tied", f.outline_tied},
          {"runtime_ms", f.runtime_ms},
          {"timing_ms", f.timing_ms},
          {"layout_confidence", f.layout_confidence},
          {"outline_unobserved", f.outline_unobserved},
          {"recipe_wrong", f.recipe_wrong},
          {"best_recipe", f.best_recipe ? nlohmann::json(*f.best_recipe) : nlohmann::json(nullptr)},
          {"truth_recipe", f.truth_recipe ? nlohmann::json(*f.truth_recipe) : nlohmann::json(nullptr)},
          {"boxes", boxes_json(f.boxes)}};
}

nlohmann::json to_json(const ScoreReport& r) {
  auto bins_json = [](const std::vector<ReliabilityBin>& bins) {
    nlohmann::json out = nlohmann::json::array();
    for (const ReliabilityBin& b : bins)
      out.push_back({{"lo", b.lo}, {"hi", b.hi}, {"n", b.n}, {"mean_score", b.mean_score}, {"right_share", b.right_share}});
    return out;
  };
  return {{"items", r.items}, {"right", r.right}, {"auc", r.auc}, {"max_bin_gap", r.max_bin_gap},
          {"max_decile_gap", r.max_decile_gap}, {"deciles", bins_json(r.deciles)},
          {"high", r.high}, {"high_right", r.high_right}, {"bins", bins_json(r.bins)}};
}

void print_score_report(const char* what, const ScoreReport& r) {
  std::printf("%s %zu (right %zu): AUC %.4f | scored >= 0.9: %zu, right %zu (%.2f %%) | largest gap: bin %.3f, "
              "decile %.3f\n",
              what, r.items, r.right, r.auc, r.high, r.high_right,
              r.high > 0 ? 100.0 * static_cast<double>(r.high_right) / static_cast<double>(r.high) : 0.0, r.max_bin_gap,
              r.max_decile_gap);
  std::printf("  score bin   n     mean   right\n");
  for (const ReliabilityBin& b : r.bins) {
    if (b.n > 0) std::printf("  %.1f-%.1f %5zu   %.3f   %.3f\n", b.lo, b.hi, b.n, b.mean_score, b.right_share);
  }
}

nlohmann::json to_json(const EvalSummary& s) {
  return {{"frames", s.frames},
          {"ok_frames", s.ok_frames},
          {"exact_frames", s.exact_frames},
          {"exact_rate", s.exact_rate},
          {"ambiguous_frames", s.ambiguous_frames},
          {"truth_boxes", s.truth_boxes},
          {"detected_boxes", s.detected_boxes},
          {"matched", s.matched},
          {"precision", s.precision},
          {"recall", s.recall},
          {"position_median_mm", s.position_median_mm},
          {"position_p95_mm", s.position_p95_mm},
          {"position_max_mm", s.position_max_mm},
          {"yaw_median_deg", s.yaw_median_deg},
          {"yaw_p95_deg", s.yaw_p95_deg},
          {"size_measured", s.size_measured},
          {"size_median_mm", s.size_median_mm},
          {"size_p95_mm", s.size_p95_mm},
          {"pairwise_mean_mm", s.pairwise_mean_mm},
          {"runtime_median_ms", s.runtime_median_ms},
          {"runtime_p95_ms", s.runtime_p95_ms},
          {"unambiguous_frames", s.unambiguous_frames},
          {"unambiguous_exact", s.unambiguous_exact},
          {"unambiguous_exact_rate", s.unambiguous_exact_rate},
          {"unambiguous_flagged", s.unambiguous_flagged},
          {"tied_frames", s.tied_frames},
          {"tied_resolved", s.tied_resolved},
          {"tied_flagged", s.tied_flagged},
          {"tied_wrong", s.tied_wrong},
          {"unflagged_wrong", s.unflagged_wrong},
          {"empty_frames", s.empty_frames},
          {"empty_right", s.empty_right},
          {"sheet_frames", s.sheet_frames},
          {"sheet_right", s.sheet_right},
          {"wrong_recipe_frames", s.wrong_recipe_frames},
          {"wrong_recipe_mismatch", s.wrong_recipe_mismatch},
          {"wrong_recipe_named", s.wrong_recipe_named},
          {"wrong_recipe_named_right", s.wrong_recipe_named_right},
          {"false_mismatch", s.false_mismatch}};
}

int run_eval(const EvalArgs& a) {
  const DetectSetup setup = make_detect_setup(a.config, a.recipe, a.boxes);
  std::vector<FrameEval> results;
  DetectionWorkspace workspace;  // rays and cloud reused from frame to frame
  if (!a.json && !a.quiet) {
    std::printf("%-48s %-9s %5s %5s %5s %8s %8s %8s %5s %8s\n", "frame", "status", "truth", "det", "match", "pos[mm]",
                "yaw[deg]", "pw[mm]", "exact", "ms");
  }
  for (const std::string& stem : expand_stems(a.dirs)) {
    Expected<Truth> truth = read_truth(stem);
    if (!truth) {
      spdlog::warn("{}: no truth, skipped ({})", stem, truth.error());
      continue;
    }
    std::vector<BoxFormat> formats = setup.formats;
    std::vector<std::string> names;
    if (formats.empty() && !setup.size_range) {
      // The cell's recipe as the truth file lists it (the detector is given these formats).
      for (std::size_t i = 0; i < truth->recipe_mm.size(); ++i) {
        const auto& mm = truth->recipe_mm[i];
        const std::string name = i < truth->recipe.size() ? truth->recipe[i] : std::string();
        formats.push_back(BoxFormat{mm[0] / 1000.0, mm[1] / 1000.0, name});
        names.push_back(name);
      }
    } else {
      for (const auto& f : formats) names.push_back(f.name);
      names.assign(names.size(), std::string());  // --box formats have no truth names to check
    }
    Expected<Frame> frame = read_frame(stem);
    Detection detection;
    if (!frame) {
      detection.status = DetectionStatus::kBadFrame;
      detection.message = frame.error();
    } else {
      const DetectionParams params = frame_params(setup.params, stem, a.cell_files);
      detection = detect_with_setup(*frame, setup, formats, params, workspace);
      name_best_recipe(*frame, setup, params, workspace, detection);
    }
    EvalOptions options;
    options.recipe_wrong = !setup.formats.empty() && !recipe_matches(formats, *truth);
    FrameEval e = evaluate_frame(detection, *truth, names, options);
    for (const RecipeCandidate& c : setup.other_recipes) {
      if (!e.truth_recipe && recipe_matches(c.formats, *truth)) e.truth_recipe = c.number;
    }
    e.frame = stem;
    e.outline_tied = truth_outline_tied(*truth, formats, names);
    if (a.json) {
      std::printf("%s\n", to_json(e).dump().c_str());
    } else if (!a.quiet) {
      const double pos = percentile(e.position_errors_mm, 50), yaw = percentile(e.yaw_errors_deg, 50);
      std::printf("%-48s %-9s %5zu %5zu %5zu %8.2f %8.2f %8.2f %5s %8.1f%s%s\n",
                  std::filesystem::path(stem).filename().string().c_str(), e.status.c_str(), e.truth_boxes,
                  e.detected_boxes, e.matched, pos, yaw, e.pairwise_error_mm, e.exact ? "yes" : "no", e.runtime_ms,
                  e.ambiguous ? "  ambiguous" : "", e.outline_tied == 1 ? "  (outline tied)" : "");
    }
    std::fflush(stdout);
    results.push_back(std::move(e));
  }
  const EvalSummary s = summarize(results);
  const ConfidenceReport confidence = confidence_report(results);
  if (a.json) {
    nlohmann::json summary = to_json(s);
    summary["box_confidence"] = to_json(confidence.boxes);
    summary["layout_confidence"] = to_json(confidence.layouts);
    std::printf("%s\n", nlohmann::json{{"summary", std::move(summary)}}.dump().c_str());
  } else {
    std::printf("\nframes %zu (ok %zu, ambiguous %zu) | exact layouts %zu (%.1f %%) | precision %.4f recall %.4f\n",
                s.frames, s.ok_frames, s.ambiguous_frames, s.exact_frames, 100.0 * s.exact_rate, s.precision, s.recall);
    std::printf("unambiguous (outline determines the truth) %zu: exact %zu (%.1f %%), flagged ambiguous %zu | "
                "outline-tied %zu: resolved %zu, flagged %zu, wrong %zu\n",
                s.unambiguous_frames, s.unambiguous_exact, 100.0 * s.unambiguous_exact_rate, s.unambiguous_flagged,
                s.tied_frames, s.tied_resolved, s.tied_flagged, s.tied_wrong);
    std::printf("unflagged wrong %zu | empty pallets %zu: empty %zu | slip sheets %zu: slip_sheet %zu\n",
                s.unflagged_wrong, s.empty_frames, s.empty_right, s.sheet_frames, s.sheet_right);
    std::printf("wrong recipe %zu: recipe_mismatch %zu, best recipe named %zu, right %zu | right recipe answered "
                "recipe_mismatch %zu\n",
                s.wrong_recipe_frames, s.wrong_recipe_mismatch, s.wrong_recipe_named, s.wrong_recipe_named_right,
                s.false_mismatch);
    std::printf("position error median %.2f mm, p95 %.2f mm, max %.2f mm | yaw median %.3f deg, p95 %.3f deg\n",
                s.position_median_mm, s.position_p95_mm, s.position_max_mm, s.yaw_median_deg, s.yaw_p95_deg);
    if (s.size_measured > 0)
      std::printf("measured carton sizes %zu boxes: error median %.1f mm, p95 %.1f mm\n", s.size_measured,
                  s.size_median_mm, s.size_p95_mm);
    std::printf("pairwise centroid-distance error (paper metric) mean %.2f mm | runtime median %.1f ms, p95 %.1f ms\n",
                s.pairwise_mean_mm, s.runtime_median_ms, s.runtime_p95_ms);
    print_score_report("box confidence: boxes", confidence.boxes);
    print_score_report("layout confidence: layouts", confidence.layouts);
  }
  return results.empty() ? 1 : 0;
}

}  // namespace

void register_eval(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand("eval", "Detect on folders of frames and score against their truth files");
  cmd->add_option("--box", args->boxes, "box formats LONGxSHORT in mm (default: each truth file's recipe)")->expected(1)->take_all();
  cmd->add_option("--config", args->config, "palletd configuration (detection parameters)");
  cmd->add_option("--recipe", args->recipe, "with --config and no --box: the recipe's formats");
  cmd->add_flag("--json", args->json, "one JSON object per frame and a summary object");
  cmd->add_flag("--cell-files", args->cell_files,
                "use STEM.roi.yaml beside a frame (detection.roi and pallet, as palletctl simulate and palletctl roi "
                "write them) for that frame");
  cmd->add_flag("-q,--quiet", args->quiet, "summary only");
  cmd->add_option("dirs", args->dirs, "folders of frames (or frame stems)")->required();
  cmd->callback([args] { throw CLI::RuntimeError(run_eval(*args)); });
}

}  // namespace palletd
