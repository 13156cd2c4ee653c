// Footprint moves decided by the seam likelihood (see seam_likelihood.hpp, retile_by_seams).
#include <algorithm>
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
  for (std::size_t i = 0; i < boxes.size(); ++i) add({i}, boxes[i].rect);
  // Pairs sharing a whole side: their union is a rectangle.
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Rect& a = boxes[i].rect;
    for (std::size_t j = 0; j < boxes.size(); ++j) {
      if (j == i) continue;
      const Rect& b = boxes[j].rect;
      if (std::abs(a.x1 - b.x0) < tol_m && std::abs(a.y0 - b.y0) < tol_m && std::abs(a.y1 - b.y1) < tol_m) {
        add({i, j}, {a.x0, a.y0, b.x1, a.y1});
      }
      if (std::abs(a.y1 - b.y0) < tol_m && std::abs(a.x0 - b.x0) < tol_m && std::abs(a.x1 - b.x1) < tol_m) {
        add({i, j}, {a.x0, a.y0, a.x1, b.y1});
      }
    }
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
                             const SeamLikelihood* lik, double tol_m, double decisive_nats) {
  RetileResult res;
  // Each applied move turns boxes into others of the same footprint; at most one move per box
  // and round, and a box count bound keeps the loop finite.
  for (std::size_t round = 0; round <= 2 * boxes->size(); ++round) {
    const std::vector<FootprintMove> moves = footprint_moves(*boxes, formats, tol_m);
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
      tied = tied || std::abs(ev) < decisive_nats;
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
