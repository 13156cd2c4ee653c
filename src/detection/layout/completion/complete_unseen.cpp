// Boxes the outline cuts where the depth ends. The outline of a layer partly beyond the sensor's
// range (or on a box too dark to measure) runs where the measurements stop, not along box edges:
// the box there shows less than A_min of its area and the search cannot place it. Such a box is
// completed when what is seen pins it down: enough of it on the layer, one side per axis on a
// seen edge of the outline (the view beyond it shows the surface lower or another box) or on a
// neighbour, and its part off the layer unseen rather than seen lower.
#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "layout_internal.hpp"

namespace palletd::layout_detail {

namespace {

/// The surroundings' labels in a layout frame, one summed-area table per label.
class SurroundTable {
 public:
  SurroundTable() = default;
  SurroundTable(const LayerSurroundings& around, const LayoutFrame& frame, const Rect& bounds) {
    cell_ = around.cell_m;
    x0_ = bounds.x0;
    y0_ = bounds.y0;
    w_ = static_cast<int>(std::ceil((bounds.x1 - bounds.x0) / cell_));
    h_ = static_cast<int>(std::ceil((bounds.y1 - bounds.y0) / cell_));
    if (around.empty() || w_ <= 0 || h_ <= 0 || static_cast<double>(w_) * h_ > 4e6) {
      w_ = h_ = 0;
      return;
    }
    // dst cell (col, row) -> frame q -> layer p -> src cell (as SeamTable).
    const double c = std::cos(frame.theta_rad), s = std::sin(frame.theta_rad);
    const double k = 1.0 / around.cell_m;
    const double qx0 = x0_ + 0.5 * cell_, qy0 = y0_ + 0.5 * cell_;
    const cv::Matx23d m(k * c * cell_, -k * s * cell_,
                        k * (c * qx0 - s * qy0 + frame.pivot.x() - around.origin_m.x()) - 0.5, k * s * cell_,
                        k * c * cell_, k * (s * qx0 + c * qy0 + frame.pivot.y() - around.origin_m.y()) - 0.5);
    const cv::Mat src(around.height, around.width, CV_8U, const_cast<std::uint8_t*>(around.label.data()));
    cv::Mat dst;
    cv::warpAffine(src, dst, m, cv::Size(w_, h_), cv::INTER_NEAREST | cv::WARP_INVERSE_MAP,
                   cv::BORDER_CONSTANT, cv::Scalar(LayerSurroundings::kUnseen));
    // One channel per label (1 where the cell has it), summed in one pass: cell counts, exact.
    cv::Mat one_hot(dst.size(), CV_8UC3, cv::Scalar::all(0));
    for (int row = 0; row < dst.rows; ++row) {
      const std::uint8_t* label = dst.ptr<std::uint8_t>(row);
      auto* out = one_hot.ptr<cv::Vec3b>(row);
      for (int col = 0; col < dst.cols; ++col) {
        if (label[col] < 3) out[col][label[col]] = 1;
      }
    }
    cv::integral(one_hot, sat_, CV_32S);
  }
  [[nodiscard]] bool empty() const { return w_ == 0; }
  /// Area [m^2] of the rectangle's cells with that label (whole cells; outside the table: unseen).
  [[nodiscard]] double area(LayerSurroundings::Label label, const Rect& r) const {
    const int ix0 = std::clamp(static_cast<int>(std::lround((r.x0 - x0_) / cell_)), 0, w_);
    const int ix1 = std::clamp(static_cast<int>(std::lround((r.x1 - x0_) / cell_)), 0, w_);
    const int iy0 = std::clamp(static_cast<int>(std::lround((r.y0 - y0_) / cell_)), 0, h_);
    const int iy1 = std::clamp(static_cast<int>(std::lround((r.y1 - y0_) / cell_)), 0, h_);
    const double inside =
        static_cast<double>(std::max(0, ix1 - ix0)) * std::max(0, iy1 - iy0) * cell_ * cell_;
    double n = 0.0;
    if (ix1 > ix0 && iy1 > iy0) {
      auto at = [&](int row, int col) { return sat_.ptr<cv::Vec3i>(row)[col][static_cast<int>(label)]; };
      n = at(iy1, ix1) - at(iy0, ix1) - at(iy1, ix0) + at(iy0, ix0);
    }
    const double a = n * cell_ * cell_;
    return label == LayerSurroundings::kUnseen ? a + std::max(0.0, r.area() - inside) : a;
  }
  [[nodiscard]] double cell() const { return cell_; }

 private:
  double x0_ = 0, y0_ = 0, cell_ = 0;
  int w_ = 0, h_ = 0;
  cv::Mat sat_;  ///< CV_32SC3: per label, the summed-area table of its cells (w_+1 x h_+1)
};

/// A box that could lie over this share of uncovered layer and the unseen beyond it, but too
/// little of it is seen to place it, leaves the layout there open.
constexpr double kOpenFraction = 0.2;

struct Anchor {
  double pos;
  bool box_on_plus;  ///< the box lies on the + side of the line
};

}  // namespace

namespace {

/// Layer area the boxes cover [m^2] (boxes of a layout barely overlap).
double covered_area(const std::vector<FrameBox>& boxes, const PolygonWithHoles& frame_polygon) {
  double a = 0.0;
  for (const auto& b : boxes) a += clipped_area(frame_polygon, b.rect.x0, b.rect.y0, b.rect.x1, b.rect.y1);
  return a;
}

/// Completion of one component's layout in its layout frame.
class Completer {
 public:
  Completer(const PolygonWithHoles& frame_polygon, const PolygonWithHoles& frame_edges,
            const LayoutFrame& frame, const std::vector<BoxFormat>& formats, const LayerSurroundings& around,
            const LayoutParams& params, const Deadline& deadline)
      : poly_(frame_polygon), formats_(formats), params_(params), deadline_(deadline) {
    double max_long = 0.0;
    for (const auto& f : formats) {
      max_long = std::max(max_long, f.long_m);
      min_short_ = std::min(min_short_, f.short_m);
      min_box_area_ = std::min(min_box_area_, f.long_m * f.short_m);
    }
    Rect bounds{1e300, 1e300, -1e300, -1e300};
    for (const auto& p : frame_polygon.outer) {
      bounds.x0 = std::min(bounds.x0, p.x());
      bounds.x1 = std::max(bounds.x1, p.x());
      bounds.y0 = std::min(bounds.y0, p.y());
      bounds.y1 = std::max(bounds.y1, p.y());
    }
    table_ = SurroundTable(
        around, frame,
        Rect{bounds.x0 - max_long, bounds.y0 - max_long, bounds.x1 + max_long, bounds.y1 + max_long});
    // Anchors: the outline's edges along the axes (a box edge may run where nothing is seen
    // beyond it: the floor out of range) and, per layout, the sides of its boxes.
    const double min_edge = min_corner_edge_m(min_short_);
    const double axis_tol = 5.0 * M_PI / 180.0;
    auto anchor_ring = [&](const Ring2d& ring, bool hole) {
      const double orient =
          (signed_area(ring) >= 0 ? 1.0 : -1.0) * (hole ? -1.0 : 1.0);  // +1: layer on the left
      for (std::size_t i = 0; i < ring.size(); ++i) {
        const Eigen::Vector2d a = ring[i], b = ring[(i + 1) % ring.size()];
        if ((b - a).norm() < min_edge) continue;
        const double ang = std::atan2(std::abs(b.y() - a.y()), std::abs(b.x() - a.x()));
        if (ang < axis_tol) {  // along x: a y line; the layer on the left of (dx, 0) is +y when dx > 0
          ay_.push_back({(a.y() + b.y()) / 2, orient * (b.x() - a.x()) > 0});
        } else if (ang >
                   M_PI / 2 - axis_tol) {  // along y: the layer on the left of (0, dy) is -x when dy > 0
          ax_.push_back({(a.x() + b.x()) / 2, orient * (a.y() - b.y()) > 0});
        }
      }
    };
    anchor_ring(frame_edges.outer, false);
    for (const auto& h : frame_edges.holes) anchor_ring(h, true);
  }

  [[nodiscard]] bool usable() const {
    return params_.completion.unseen_min_fraction > 0.0 && !table_.empty() && !formats_.empty() &&
           poly_.outer.size() >= 3;
  }

  /// The completion of `boxes`: each first box the view allows, then the best box after box;
  /// the one explaining most of the layer. Stops when the deadline passes (timed_out).
  UnseenCompletion complete(const std::vector<FrameBox>& boxes) const {
    UnseenCompletion out;
    out.boxes = boxes;
    const std::vector<Found> first = candidates(boxes, &out.open, &out.timed_out);
    if (first.empty() || out.timed_out) return out;
    const double tie = tie_margin_m2(params_, formats_);
    double best_area = -1.0;
    std::vector<std::vector<FrameBox>> tried;
    for (std::size_t k = 0; k < first.size() && tried.size() < kFirstMoves; ++k) {
      std::vector<FrameBox> start = boxes;
      start.push_back(first[k].box);
      bool seen_before = false;
      for (const auto& t : tried) seen_before = seen_before || same_layout(t, start, 0.5 * min_short_);
      if (seen_before) continue;
      tried.push_back(start);
      UnseenCompletion c = greedy(std::move(start));
      c.added += 1;
      out.timed_out = out.timed_out || c.timed_out;
      const double a = covered_area(c.boxes, poly_);
      if (a > best_area + tie) {
        out = std::move(c);
        best_area = a;
      } else if (a > best_area - tie && !same_layout(c.boxes, out.boxes, 0.5 * min_short_)) {
        out.tied = true;  // another completion explains the view as well
      }
      if (out.timed_out) break;
    }
    return out;
  }

 private:
  struct Found {
    FrameBox box;
    double gain = -1.0;
    double below = 0.0;
  };
  static constexpr std::size_t kFirstMoves = 8;

  /// Boxes that complete `boxes` by one, most newly covered layer first. *open: some box could
  /// lie over uncovered layer and the unseen beyond it but too little of it is seen. *timed_out:
  /// the deadline passed before every place was tried (those found by then are returned).
  std::vector<Found> candidates(const std::vector<FrameBox>& boxes, bool* open, bool* timed_out) const {
    std::vector<Anchor> bx = ax_, by = ay_;
    for (const auto& b : boxes) {  // beside a box (either way along its side)
      for (bool plus : {true, false}) {
        bx.push_back({b.rect.x1, plus});
        bx.push_back({b.rect.x0, plus});
        by.push_back({b.rect.y1, plus});
        by.push_back({b.rect.y0, plus});
      }
    }
    // Boxes of a layout share their side lines: each line once.
    for (std::vector<Anchor>* v : {&bx, &by}) {
      std::sort(v->begin(), v->end(), [](const Anchor& a, const Anchor& b) {
        return a.box_on_plus != b.box_on_plus ? a.box_on_plus : a.pos < b.pos;
      });
      v->erase(std::unique(v->begin(), v->end(),
                           [](const Anchor& a, const Anchor& b) {
                             return a.box_on_plus == b.box_on_plus && std::abs(a.pos - b.pos) < 1e-4;
                           }),
               v->end());
    }
    std::vector<Found> found;
    *open = false;
    for (std::size_t f = 0; f < formats_.size(); ++f) {
      for (int turn = 0; turn < 2; ++turn) {
        const bool long_x = turn == 0;
        if (!long_x && formats_[f].long_m - formats_[f].short_m < 1e-6) continue;
        const double w = long_x ? formats_[f].long_m : formats_[f].short_m;
        const double h = long_x ? formats_[f].short_m : formats_[f].long_m;
        const double box_area = w * h;
        for (const Anchor& x : bx) {
          if (deadline_.passed()) {
            *timed_out = true;
            break;
          }
          for (const Anchor& y : by) {
            const Rect r{x.box_on_plus ? x.pos : x.pos - w, y.box_on_plus ? y.pos : y.pos - h,
                         x.box_on_plus ? x.pos + w : x.pos, y.box_on_plus ? y.pos + h : y.pos};
            // A completion: part of the box is unseen, little of it is seen lower (the tables'
            // constant-time tests first: most places fail them), it takes little of the boxes,
            // and the layer with what is unseen carries it as the search's A_min would.
            const double unseen = table_.area(LayerSurroundings::kUnseen, r);
            const double below = table_.area(LayerSurroundings::kBelow, r);
            if (unseen < 0.05 * box_area || below > (1.0 - params_.search.a_min_fraction) * box_area) continue;
            double taken = 0.0;
            for (const auto& b : boxes) taken += overlap(r, b.rect);
            if (taken >= params_.search.a_max_fraction * box_area) continue;
            const double on_layer = clipped_area(poly_, r.x0, r.y0, r.x1, r.y1);
            const double gain = on_layer - taken;
            if (gain < kOpenFraction * box_area) continue;
            const double level_off = std::max(0.0, table_.area(LayerSurroundings::kLevel, r) - on_layer);
            if (on_layer + unseen + level_off < params_.search.a_min_fraction * box_area) continue;
            if (gain < params_.completion.unseen_min_fraction * box_area) {
              *open = true;
              continue;
            }
            found.push_back({FrameBox{r, static_cast<int>(f), long_x}, gain, below});
          }
        }
      }
    }
    std::sort(found.begin(), found.end(), [](const Found& a, const Found& b) {
      return a.gain != b.gain ? a.gain > b.gain : a.below < b.below;
    });
    return found;
  }

  /// Adds the best box while there is one (the last ones of `boxes` in the answer are added).
  UnseenCompletion greedy(std::vector<FrameBox> boxes) const {
    UnseenCompletion out;
    const double tie = tie_margin_m2(params_, formats_);
    for (int round = 0; round < 16 && !out.timed_out; ++round) {
      const std::vector<Found> found = candidates(boxes, &out.open, &out.timed_out);
      if (found.empty()) break;
      const Found& best = found.front();
      // Another placement of the same spot that explains the layer as well: the view cannot tell.
      for (std::size_t k = 1; k < found.size() && best.gain - found[k].gain < tie; ++k) {
        const FrameBox& o = found[k].box;
        const bool same =
            o.long_along_x == best.box.long_along_x &&
            std::hypot(o.rect.x0 + o.rect.x1 - best.box.rect.x0 - best.box.rect.x1,
                       o.rect.y0 + o.rect.y1 - best.box.rect.y0 - best.box.rect.y1) < 0.5 * min_short_;
        if (!same && overlap(o.rect, best.box.rect) > 0.0) out.tied = true;
      }
      boxes.push_back(best.box);
      ++out.added;
    }
    out.boxes = std::move(boxes);
    return out;
  }

  const PolygonWithHoles& poly_;
  const std::vector<BoxFormat>& formats_;
  const LayoutParams& params_;
  Deadline deadline_;
  SurroundTable table_;
  double min_short_ = 1e9, min_box_area_ = 1e9;
  std::vector<Anchor> ax_, ay_;
};

UnseenCompletion complete_boxes(const std::vector<FrameBox>& boxes, const PolygonWithHoles& frame_polygon,
                                const PolygonWithHoles& frame_edges, const LayoutFrame& frame,
                                const std::vector<BoxFormat>& formats, const LayerSurroundings& around,
                                const LayoutParams& params, const Deadline& deadline) {
  const Completer completer(frame_polygon, frame_edges, frame, formats, around, params, deadline);
  if (!completer.usable()) {
    UnseenCompletion out;
    out.boxes = boxes;
    return out;
  }
  return completer.complete(boxes);
}

}  // namespace

UnseenCompletion complete_unseen(const std::vector<FrameBox>& boxes, const PolygonWithHoles& frame_polygon,
                                 const PolygonWithHoles& frame_edges, const LayoutFrame& frame,
                                 const std::vector<BoxFormat>& formats, const LayerSurroundings& around,
                                 const LayoutParams& params, const Deadline& deadline,
                                 const SearchBudget* research) {
  UnseenCompletion first =
      complete_boxes(boxes, frame_polygon, frame_edges, frame, formats, around, params, deadline);
  if (first.timed_out || research == nullptr || around.empty() ||
      !(params.completion.unseen_min_fraction > 0.0))
    return first;
  // An outline edge is seen when something (the surface lower, another box) shows beyond it
  // within 50 mm (LayerParams::unobserved_gap_m's default) along most of it.
  const SeedEdgeFilter seen_edge = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                       const Eigen::Vector2d& out) {
    const Eigen::Vector2d out_l = frame.to_layer(out) - frame.to_layer(Eigen::Vector2d::Zero());
    int seen = 0;
    for (int k = 0; k < 5; ++k) {
      const Eigen::Vector2d p = a + (0.1 + 0.2 * k) * (b - a) + 1.5 * around.cell_m * out;
      if (around.seen_within(frame.to_layer(p), out_l, 0.05)) ++seen;
    }
    return seen >= 3;
  };
  bool unseen_edge = false;
  auto check_ring = [&](const Ring2d& ring, bool hole) {
    const double orient = (signed_area(ring) >= 0 ? 1.0 : -1.0) * (hole ? -1.0 : 1.0);
    for (std::size_t i = 0; i < ring.size(); ++i) {
      const Eigen::Vector2d a = ring[i], b = ring[(i + 1) % ring.size()];
      const double len = (b - a).norm();
      if (len < 0.02) continue;
      unseen_edge =
          unseen_edge || !seen_edge(a, b, orient * Eigen::Vector2d(b.y() - a.y(), a.x() - b.x()) / len);
    }
  };
  check_ring(frame_edges.outer, false);
  for (const auto& h : frame_edges.holes) check_ring(h, true);
  const double comp_area = area(frame_polygon);
  const double covered = covered_area(first.boxes, frame_polygon);
  if (!unseen_edge || (!first.open && covered >= 0.97 * comp_area)) return first;
  // The search may have lined boxes up on an edge that is only where the depth ends: search
  // again with candidate lines from the seen edges alone, complete, keep the better explained.
  const ComponentSolution again =
      search_best_first(frame_polygon, frame_edges, formats, params, nullptr, *research, -1e300, seen_edge);
  // Its near-equal layouts differ where the seen part cannot tell: each completed, the best
  // explained one (ties to the search's order).
  std::vector<std::vector<FrameBox>> layouts{again.found ? again.boxes : std::vector<FrameBox>{}};
  for (const auto& alt : again.alternatives) layouts.push_back(alt);
  UnseenCompletion best = first;
  double best_covered = covered + 0.02 * comp_area;
  bool timed_out = false;
  for (const auto& layout : layouts) {
    if (timed_out) break;
    UnseenCompletion c =
        complete_boxes(layout, frame_polygon, frame_edges, frame, formats, around, params, deadline);
    timed_out = c.timed_out;
    const double a = covered_area(c.boxes, frame_polygon);
    if (a > best_covered) {
      best = std::move(c);
      best_covered = a;
    }
  }
  best.expansions = again.expansions;
  best.timed_out = timed_out;
  return best;
}

}  // namespace palletd::layout_detail
