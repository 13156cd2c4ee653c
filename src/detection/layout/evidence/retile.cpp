// Footprint moves decided by the seam likelihood (see seam_likelihood.hpp, retile_by_seams).
#include <algorithm>
#include <array>
#include <cmath>

#include "evidence/seam_likelihood.hpp"

namespace palletd::layout_detail {

namespace {

struct Shape {
  double dx, dy;
  int format;
  bool long_along_x;
};

std::vector<Shape> shapes_of(const std::vector<BoxFormat>& formats) {
  std::vector<Shape> out;
  for (std::size_t f = 0; f < formats.size(); ++f) {
    out.push_back({formats[f].long_m, formats[f].short_m, static_cast<int>(f), true});
    if (formats[f].long_m - formats[f].short_m > 1e-6) {
      out.push_back({formats[f].short_m, formats[f].long_m, static_cast<int>(f), false});
    }
  }
  return out;
}

bool same_box(const FrameBox& a, const FrameBox& b, double tol) {
  return a.format == b.format && a.long_along_x == b.long_along_x && std::abs(a.rect.x0 - b.rect.x0) < tol &&
         std::abs(a.rect.y0 - b.rect.y0) < tol && std::abs(a.rect.x1 - b.rect.x1) < tol &&
         std::abs(a.rect.y1 - b.rect.y1) < tol;
}

/// Every tiling of rectangle r by one or two boxes of the recipe (two side by side or stacked,
/// the split on a box side; sizes within tol). Boxes keep their nominal size from the split
/// line; the outer sides stay those of r.
std::vector<std::vector<FrameBox>> tilings(const Rect& r, const std::vector<Shape>& shapes, double tol) {
  std::vector<std::vector<FrameBox>> out;
  const double w = r.x1 - r.x0, h = r.y1 - r.y0;
  for (const Shape& a : shapes) {
    if (std::abs(a.dx - w) < tol && std::abs(a.dy - h) < tol) out.push_back({{r, a.format, a.long_along_x}});
  }
  for (const Shape& a : shapes) {
    for (const Shape& b : shapes) {
      // Side by side along x: a on the left.
      if (std::abs(a.dy - h) < tol && std::abs(b.dy - h) < tol && std::abs(a.dx + b.dx - w) < tol) {
        const double split = r.x0 + w * a.dx / (a.dx + b.dx);
        out.push_back({{{r.x0, r.y0, split, r.y1}, a.format, a.long_along_x},
                       {{split, r.y0, r.x1, r.y1}, b.format, b.long_along_x}});
      }
      // Stacked along y: a at the bottom.
      if (std::abs(a.dx - w) < tol && std::abs(b.dx - w) < tol && std::abs(a.dy + b.dy - h) < tol) {
        const double split = r.y0 + h * a.dy / (a.dy + b.dy);
        out.push_back({{{r.x0, r.y0, r.x1, split}, a.format, a.long_along_x},
                       {{r.x0, split, r.x1, r.y1}, b.format, b.long_along_x}});
      }
    }
  }
  return out;
}

/// How two boxes split a span with some to spare: the share of the spare left outside them (the
/// rest is the gap between them), from all in the gap to the boxes meeting in the middle.
constexpr std::array<double, 4> kOutsideShares{0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0};

Rect transposed(const Rect& r) { return {r.y0, r.x0, r.y1, r.x1}; }

/// A box's size along the split direction and across it.
struct Span {
  double along, across;
};

/// Two boxes a and b side by side along x inside r (a at the low end), with share of the spare
/// length outside them, each low, centred or high across: the placements when both fall short
/// of r by more than tol and at most slack and the split line is not r's long middle.
std::vector<std::array<Rect, 2>> splits_along_x(const Rect& r, Span a, Span b, double share, double tol,
                                                double slack) {
  const double w = r.x1 - r.x0, h = r.y1 - r.y0;
  auto fits = [&](double need, double have) { return need <= have + tol && need >= have - slack; };
  const bool exact =
      std::abs(a.across - h) < tol && std::abs(b.across - h) < tol && std::abs(a.along + b.along - w) < tol;
  const bool long_middle =
      h > w && std::abs(r.x0 + a.along + 0.5 * (w - a.along - b.along) - 0.5 * (r.x0 + r.x1)) < tol;
  if (!fits(a.across, h) || !fits(b.across, h) || !fits(a.along + b.along, w) || exact || long_middle)
    return {};
  auto across = [&](double size, int k) {  // k: low, centred, high
    const double spare = std::max(0.0, h - size);
    const double lo = k == 0 ? r.y0 : (k == 1 ? r.y0 + 0.5 * spare : r.y1 - size);
    return std::pair<double, double>{lo, std::min(r.y1, lo + size)};
  };
  const double outer = 0.5 * share * std::max(0.0, w - a.along - b.along);
  std::vector<std::array<Rect, 2>> out;
  for (int k = 0; k < 3; ++k) {
    const auto [ya0, ya1] = across(a.across, k);
    const auto [yb0, yb1] = across(b.across, k);
    out.push_back({Rect{r.x0 + outer, ya0, r.x0 + outer + a.along, ya1},
                   Rect{r.x1 - outer - b.along, yb0, r.x1 - outer, yb1}});
  }
  return out;
}

/// Splits of r into two boxes of the recipe whose sizes fall short of r by more than tol and at
/// most slack: the boxes a larger box was laid over, with their gaps. The split line never runs
/// along r's long middle (tape along a carton's flaps lies there).
std::vector<std::vector<FrameBox>> short_splits(const Rect& r, const std::vector<Shape>& shapes, double tol,
                                                double slack) {
  std::vector<std::vector<FrameBox>> out;
  for (const Shape& a : shapes) {
    for (const Shape& b : shapes) {
      auto add = [&](const std::array<Rect, 2>& p) {
        out.push_back({{p[0], a.format, a.long_along_x}, {p[1], b.format, b.long_along_x}});
      };
      for (const double share : kOutsideShares) {
        for (const auto& p : splits_along_x(r, {a.dx, a.dy}, {b.dx, b.dy}, share, tol, slack)) add(p);
        // Along y: the same in r transposed.
        for (const auto& p : splits_along_x(transposed(r), {a.dy, a.dx}, {b.dy, b.dx}, share, tol, slack)) {
          add({transposed(p[0]), transposed(p[1])});
        }
      }
    }
  }
  return out;
}

bool same_tiling(const std::vector<FrameBox>& a, const std::vector<FrameBox>& b, double tol) {
  if (a.size() != b.size()) return false;
  for (const auto& x : a) {
    bool hit = false;
    for (const auto& y : b) hit = hit || same_box(x, y, tol);
    if (!hit) return false;
  }
  return true;
}

}  // namespace

std::vector<FootprintMove> footprint_moves(const std::vector<FrameBox>& boxes, const std::vector<BoxFormat>& formats,
                                           double tol_m) {
  const std::vector<Shape> shapes = shapes_of(formats);
  std::vector<FootprintMove> moves;
  auto add = [&](std::vector<std::size_t> idx, const Rect& r) {
    std::vector<FrameBox> now;
    for (std::size_t i : idx) now.push_back(boxes[i]);
    for (auto& t : tilings(r, shapes, tol_m)) {
      if (same_tiling(t, now, tol_m)) continue;
      moves.push_back({idx, std::move(t)});
    }
  };
  // One box over a pair that stands a gap apart (up to kMaxCartonGap_m): a carton built over its
  // format fills both and the gap; the box spans the pair's rectangle.
  auto add_over_gap = [&](std::vector<std::size_t> idx, const Rect& r, double gap_m, bool along_x) {
    const double w = r.x1 - r.x0, h = r.y1 - r.y0;
    for (const Shape& s : shapes) {
      const double along = along_x ? s.dx : s.dy, across = along_x ? s.dy : s.dx;
      const double span = along_x ? w : h, width = along_x ? h : w;
      if (std::abs(across - width) < tol_m && along >= span - gap_m - tol_m && along <= span + tol_m)
        moves.push_back({idx, {{r, s.format, s.long_along_x}}});
    }
  };
  for (std::size_t i = 0; i < boxes.size(); ++i) add({i}, boxes[i].rect);
  // Pairs sharing a whole side (their union is a rectangle), or standing a gap apart.
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Rect& a = boxes[i].rect;
    for (std::size_t j = 0; j < boxes.size(); ++j) {
      if (j == i) continue;
      const Rect& b = boxes[j].rect;
      const double gap_x = b.x0 - a.x1, gap_y = b.y0 - a.y1;
      if (std::abs(a.y0 - b.y0) < tol_m && std::abs(a.y1 - b.y1) < tol_m) {
        if (std::abs(gap_x) < tol_m) add({i, j}, {a.x0, a.y0, b.x1, a.y1});
        if (gap_x >= tol_m && gap_x <= kMaxCartonGap_m + tol_m)
          add_over_gap({i, j}, {a.x0, a.y0, b.x1, a.y1}, gap_x, true);
      }
      if (std::abs(a.x0 - b.x0) < tol_m && std::abs(a.x1 - b.x1) < tol_m) {
        if (std::abs(gap_y) < tol_m) add({i, j}, {a.x0, a.y0, a.x1, b.y1});
        if (gap_y >= tol_m && gap_y <= kMaxCartonGap_m + tol_m)
          add_over_gap({i, j}, {a.x0, a.y0, a.x1, b.y1}, gap_y, false);
      }
    }
  }
  return moves;
}

std::vector<FootprintMove> split_moves(const std::vector<FrameBox>& boxes,
                                       const std::vector<BoxFormat>& formats, double tol_m, double slack_m) {
  const std::vector<Shape> shapes = shapes_of(formats);
  std::vector<FootprintMove> moves;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    for (auto& t : short_splits(boxes[i].rect, shapes, tol_m, slack_m)) moves.push_back({{i}, std::move(t)});
  }
  return moves;
}

std::vector<FrameBox> moves_overlay(const std::vector<FrameBox>& boxes, const std::vector<FootprintMove>& moves) {
  std::vector<bool> moved(boxes.size(), false);
  for (const auto& m : moves) {
    for (std::size_t i : m.remove) moved[i] = true;
  }
  std::vector<FrameBox> out;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    if (!moved[i]) out.push_back(boxes[i]);
  }
  for (const auto& m : moves) out.insert(out.end(), m.add.begin(), m.add.end());
  return out;
}

RetileResult retile_by_seams(std::vector<FrameBox>* boxes, const std::vector<BoxFormat>& formats,
                             const SeamLikelihood* lik, double tol_m, double slack_m, double decisive_nats) {
  RetileResult res;
  // Each applied move turns boxes into others of the same footprint (or splits one into the two
  // it was laid over); at most one move per box and round, and a box count bound keeps the loop
  // finite.
  for (std::size_t round = 0; round <= 2 * boxes->size(); ++round) {
    std::vector<FootprintMove> moves = footprint_moves(*boxes, formats, tol_m);
    const std::size_t outline_equal = moves.size();
    if (lik != nullptr && lik->usable()) {
      // Splits leave the gaps uncovered: only a seam that shows decides for one, never a tie.
      std::vector<FootprintMove> splits = split_moves(*boxes, formats, tol_m, slack_m);
      moves.insert(moves.end(), std::make_move_iterator(splits.begin()),
                   std::make_move_iterator(splits.end()));
    }
    if (moves.empty()) return res;
    if (lik == nullptr || (!lik->usable() && !lik->reads_tape())) {
      res.tied = true;  // outline-equal layouts and no usable seams
      return res;
    }
    double best_ev = -1e300;
    std::size_t best = 0;
    bool tied = false;
    for (std::size_t k = 0; k < moves.size(); ++k) {
      std::vector<FrameBox> now;
      for (std::size_t i : moves[k].remove) now.push_back((*boxes)[i]);
      // Only the footprint changes, so the pieces where the two layouts differ lie inside it.
      const double ev = lik->compare(moves[k].add, now);
      if (ev > best_ev) {
        best_ev = ev;
        best = k;
      }
      tied = tied || (k < outline_equal && std::abs(ev) < decisive_nats);
    }
    if (best_ev < decisive_nats) {
      res.tied = tied;
      return res;
    }
    const FootprintMove& m = moves[best];
    std::vector<FrameBox> next = moves_overlay(*boxes, {m});
    boxes->swap(next);
    ++res.applied;
  }
  return res;
}

}  // namespace palletd::layout_detail
