// palletd_fit_confidence fit [--l2 X] EVAL.jsonl... [--check HELD.jsonl...]
//                                                  fits the confidence models, prints their weights
// palletd_fit_confidence plot OUT.png EVAL.jsonl...  reliability plot of the scores as detected
//
// Input: the output of `palletctl eval DIR --json` (one object per frame, each with its boxes'
// box_features() and whether each box is right). `fit` fits the box model (P(box right)) by
// L2-penalised logistic regression, then the layout model (P(layout exact)) on the layouts'
// features computed with the new box model, and prints both as the C++ arrays of
// src/detection/confidence.cpp with the report on the fitting set and, after --check, on sets
// it was not fitted on (scored with the new weights from their features). `plot` draws the share of
// right boxes and exact layouts per score bin against the mean score (docs/confidence.png).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/detection/confidence.hpp"
#include "palletd/results/confidence_eval.hpp"

using namespace palletd;

namespace {

struct FrameRow {
  std::vector<std::vector<double>> features;  ///< per box
  std::vector<bool> right;                    ///< per box
  std::vector<double> scores;                 ///< per box, as detected
  bool ambiguous = false, outline_unobserved = false, exact = false;
  double layout_confidence = 0.0;
};

bool read_rows(const std::vector<std::string>& files, std::vector<FrameRow>& rows) {
  for (const std::string& file : files) {
    std::ifstream in(file);
    if (!in) {
      std::fprintf(stderr, "%s: cannot be read\n", file.c_str());
      return false;
    }
    std::string line;
    while (std::getline(in, line)) {
      const nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
      if (j.is_discarded() || !j.contains("boxes") || !j["boxes"].is_array()) continue;  // the summary
      FrameRow r;
      for (const auto& b : j["boxes"]) {
        r.features.push_back(b.at("features").get<std::vector<double>>());
        r.right.push_back(b.at("right").get<bool>());
        r.scores.push_back(b.at("score").get<double>());
      }
      r.ambiguous = j.value("ambiguous", false);
      r.outline_unobserved = j.value("outline_unobserved", false);
      r.exact = j.value("exact", false);
      r.layout_confidence = j.value("layout_confidence", 0.0);
      rows.push_back(std::move(r));
    }
  }
  return true;
}

double predict(const std::vector<double>& w, const std::vector<double>& x) {
  double z = 0.0;
  for (std::size_t i = 0; i < w.size() && i < x.size(); ++i) z += w[i] * x[i];
  return logistic(z);
}

void print_weights(const char* name, const std::vector<double>& w) {
  std::printf("%s = {", name);
  for (std::size_t i = 0; i < w.size(); ++i) std::printf("%s%.6g", i == 0 ? "" : ", ", w[i]);
  std::printf("};\n");
}

void print_report(const char* what, const ScoreReport& r) {
  std::printf(
      "%s: %zu (right %zu), AUC %.4f, scored >= 0.9: %zu (right %zu), largest bin gap %.3f, largest decile "
      "gap %.3f\n",
      what, r.items, r.right, r.auc, r.high, r.high_right, r.max_bin_gap, r.max_decile_gap);
  for (const ReliabilityBin& b : r.deciles) {
    std::printf("  decile %.3f-%.3f: %5zu, mean score %.3f, right %.3f\n", b.lo, b.hi, b.n, b.mean_score,
                b.right_share);
  }
  for (const ReliabilityBin& b : r.bins) {
    if (b.n > 0)
      std::printf("  %.1f-%.1f: %5zu, mean score %.3f, right %.3f\n", b.lo, b.hi, b.n, b.mean_score,
                  b.right_share);
  }
}

/// Box and layout probabilities of `rows` under the given weights.
void score_rows(const std::vector<FrameRow>& rows, const std::vector<double>& box_w,
                const std::vector<double>& layout_w, std::vector<double>& box_scores,
                std::vector<bool>& box_right, std::vector<double>& layout_scores,
                std::vector<bool>& layout_exact) {
  for (const FrameRow& r : rows) {
    std::vector<double> p;
    for (const auto& f : r.features) p.push_back(predict(box_w, f));
    box_scores.insert(box_scores.end(), p.begin(), p.end());
    box_right.insert(box_right.end(), r.right.begin(), r.right.end());
    if (p.empty()) continue;
    const auto lf = layout_features(p, r.ambiguous, r.outline_unobserved);
    layout_scores.push_back(predict(layout_w, std::vector<double>(lf.begin(), lf.end())));
    layout_exact.push_back(r.exact);
  }
}

int fit(const std::vector<FrameRow>& rows, double l2, const std::vector<FrameRow>& held_out) {
  std::vector<std::vector<double>> x;
  std::vector<bool> y;
  for (const FrameRow& r : rows) {
    x.insert(x.end(), r.features.begin(), r.features.end());
    y.insert(y.end(), r.right.begin(), r.right.end());
  }
  const LogisticFit box = fit_logistic(x, y, l2);
  // The layout model's inputs come from the new box model's confidences.
  std::vector<std::vector<double>> lx;
  std::vector<bool> ly;
  for (const FrameRow& r : rows) {
    if (r.features.empty()) continue;
    std::vector<double> p;
    for (const auto& f : r.features) p.push_back(predict(box.weights, f));
    const auto lf = layout_features(p, r.ambiguous, r.outline_unobserved);
    lx.emplace_back(lf.begin(), lf.end());
    ly.push_back(r.exact);
  }
  const LogisticFit layout = fit_logistic(lx, ly, l2);
  std::printf(
      "// fitted on %zu boxes of %zu layouts (l2 %.g); box fit %s after %d iterations, layout fit %s after "
      "%d\n",
      x.size(), lx.size(), l2, box.converged ? "converged" : "NOT converged", box.iterations,
      layout.converged ? "converged" : "NOT converged", layout.iterations);
  print_weights("kBoxWeights", box.weights);
  print_weights("kLayoutWeights", layout.weights);
  for (const auto& [set, name] : {std::pair{&rows, "fitting set"}, std::pair{&held_out, "held out"}}) {
    if (set->empty()) continue;
    std::vector<double> bs, ls;
    std::vector<bool> br, lr;
    score_rows(*set, box.weights, layout.weights, bs, br, ls, lr);
    print_report((std::string("boxes (") + name + ")").c_str(), score_report(bs, br));
    print_report((std::string("layouts (") + name + ")").c_str(), score_report(ls, lr));
  }
  return box.converged && layout.converged ? 0 : 1;
}

/// One reliability panel: bins as points sized by count, the diagonal, the axes.
void draw_panel(cv::Mat& img, const cv::Rect& area, const std::vector<ReliabilityBin>& bins,
                const std::string& title) {
  const cv::Scalar ink(40, 40, 40), grid(210, 210, 210), dot(180, 90, 20);
  auto at = [&](double sx, double sy) {
    return cv::Point(area.x + static_cast<int>(std::lround(sx * area.width)),
                     area.y + area.height - static_cast<int>(std::lround(sy * area.height)));
  };
  for (int k = 0; k <= 10; ++k) {
    cv::line(img, at(k / 10.0, 0), at(k / 10.0, 1), grid, 1);
    cv::line(img, at(0, k / 10.0), at(1, k / 10.0), grid, 1);
  }
  cv::line(img, at(0, 0), at(1, 1), ink, 1, cv::LINE_AA);
  cv::rectangle(img, area, ink, 1);
  cv::Point last(-1, -1);
  for (const ReliabilityBin& b : bins) {
    if (b.n == 0) continue;
    const cv::Point p = at(b.mean_score, b.right_share);
    if (last.x >= 0) cv::line(img, last, p, dot, 2, cv::LINE_AA);
    cv::circle(img, p, 3 + static_cast<int>(std::lround(2.0 * std::log10(1.0 + static_cast<double>(b.n)))),
               dot, cv::FILLED, cv::LINE_AA);
    cv::putText(img, std::to_string(b.n), p + cv::Point(8, 14), cv::FONT_HERSHEY_SIMPLEX, 0.35, ink, 1,
                cv::LINE_AA);
    last = p;
  }
  cv::putText(img, title, cv::Point(area.x, area.y - 10), cv::FONT_HERSHEY_SIMPLEX, 0.5, ink, 1, cv::LINE_AA);
  cv::putText(img, "mean score per bin", cv::Point(area.x + area.width / 2 - 60, area.y + area.height + 30),
              cv::FONT_HERSHEY_SIMPLEX, 0.45, ink, 1, cv::LINE_AA);
  cv::putText(img, "y: share right", cv::Point(area.x + 6, area.y + 16), cv::FONT_HERSHEY_SIMPLEX, 0.4, ink,
              1, cv::LINE_AA);
  for (const double t : {0.0, 0.5, 1.0}) {
    char label[8];
    std::snprintf(label, sizeof label, "%.1f", t);
    cv::putText(img, label, at(t, 0) + cv::Point(-10, 16), cv::FONT_HERSHEY_SIMPLEX, 0.4, ink, 1,
                cv::LINE_AA);
    cv::putText(img, label, at(0, t) + cv::Point(-30, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4, ink, 1, cv::LINE_AA);
  }
}

int plot(const std::string& out, const std::vector<FrameRow>& rows) {
  std::vector<double> bs, ls;
  std::vector<bool> br, lr;
  for (const FrameRow& r : rows) {
    bs.insert(bs.end(), r.scores.begin(), r.scores.end());
    br.insert(br.end(), r.right.begin(), r.right.end());
    if (r.scores.empty()) continue;
    ls.push_back(r.layout_confidence);
    lr.push_back(r.exact);
  }
  const ScoreReport b = score_report(bs, br), l = score_report(ls, lr);
  print_report("boxes", b);
  print_report("layouts", l);
  cv::Mat img(460, 860, CV_8UC3, cv::Scalar(255, 255, 255));
  char title[160];
  std::snprintf(title, sizeof title, "boxes: %zu, AUC %.3f", b.items, b.auc);
  draw_panel(img, cv::Rect(50, 40, 360, 360), b.bins, title);
  std::snprintf(title, sizeof title, "layouts: %zu, AUC %.3f", l.items, l.auc);
  draw_panel(img, cv::Rect(470, 40, 360, 360), l.bins, title);
  if (!cv::imwrite(out, img)) {
    std::fprintf(stderr, "%s: cannot be written\n", out.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string usage =
      "usage: palletd_fit_confidence fit [--l2 X] EVAL.jsonl... [--check HELD.jsonl...] | plot OUT.png "
      "EVAL.jsonl...\n";
  if (argc < 3) {
    std::fputs(usage.c_str(), stderr);
    return 2;
  }
  const std::string mode = argv[1];
  int first = 2;
  double l2 = 1e-3;
  std::string out;
  if (mode == "fit" && std::string(argv[2]) == "--l2" && argc > 4) {
    l2 = std::stod(argv[3]);
    first = 4;
  } else if (mode == "plot") {
    out = argv[2];
    first = 3;
  } else if (mode != "fit") {
    std::fputs(usage.c_str(), stderr);
    return 2;
  }
  std::vector<std::string> files(argv + first, argv + argc), held_files;
  const auto check = std::find(files.begin(), files.end(), std::string("--check"));
  if (check != files.end()) {
    held_files.assign(check + 1, files.end());
    files.erase(check, files.end());
  }
  std::vector<FrameRow> rows, held_out;
  if (!read_rows(files, rows) || !read_rows(held_files, held_out)) return 1;
  if (rows.empty()) {
    std::fputs("no frames in the input\n", stderr);
    return 1;
  }
  return mode == "fit" ? fit(rows, l2, held_out) : plot(out, rows);
}
