// Refinement (issue 5): the joint fit of a layout's boxes to outline points and seam lines.
// Seeded synthetic layers: true boxes with gaps, size deviations and small yaw; the search's
// answer is the packed nominal grid; refine_layout must recover the true poses.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <utility>

#include "../../src/detection/layout/refinement/refine_joint.hpp"
#include "layout_fixtures.hpp"
#include "palletd/detection/layout.hpp"

using namespace palletd;

namespace {

struct TrueBox {
  Eigen::Vector2d center;
  double long_m, short_m, yaw_rad;
};

bool inside(const TrueBox& b, const Eigen::Vector2d& p) {
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  const Eigen::Vector2d d = p - b.center;
  return std::abs(c * d.x() + s * d.y()) <= b.long_m / 2 && std::abs(-s * d.x() + c * d.y()) <= b.short_m / 2;
}

/// A patch on a box top that looks like a seam in the raster (label edge, tape) [layer frame].
struct Patch {
  double x0, y0, x1, y1;
};

/// The refinement input (layer, seams, the search's answer) with the true boxes.
struct Scene : layout_test::RefineInput {
  std::vector<TrueBox> truth;
};

const std::vector<BoxFormat> kFormats{BoxFormat{0.4, 0.3, "400x300"}};

/// cols x rows boxes of 400 x 300 (long along x). gaps_x[c] is the gap after column c.
/// The layer outline is the rectangle around all boxes; the search's answer is the nominal
/// grid packed against the outline's lower-left corner.
Scene make_block(int cols, int rows, const std::vector<double>& gaps_x, const std::vector<double>& gaps_y,
                 double size_dev_m, double jitter_m, double yaw_dev_rad, std::mt19937& rng,
                 const std::vector<Patch>& patches = {}, double pitch_m = 0.003, double built_scale = 1.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Scene s;
  const double L = 0.4 * built_scale, S = 0.3 * built_scale;
  double x = 0;
  std::vector<double> xs, ys;
  for (int c = 0; c < cols; ++c) { xs.push_back(x); x += L + (c < cols - 1 ? gaps_x[static_cast<std::size_t>(c)] : 0); }
  double y = 0;
  for (int r = 0; r < rows; ++r) { ys.push_back(y); y += S + (r < rows - 1 ? gaps_y[static_cast<std::size_t>(r)] : 0); }
  double bx0 = 1e9, by0 = 1e9, bx1 = -1e9, by1 = -1e9;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      TrueBox b;
      b.long_m = L + size_dev_m * u(rng);
      b.short_m = S + size_dev_m * u(rng);
      b.yaw_rad = yaw_dev_rad * u(rng);
      // One draw per statement (argument evaluation order is unspecified): y before x, the
      // order gcc used when these scenes were tuned.
      const double jitter_y_m = jitter_m * u(rng);
      const double jitter_x_m = jitter_m * u(rng);
      b.center = Eigen::Vector2d(xs[static_cast<std::size_t>(c)] + L / 2 + jitter_x_m,
                                 ys[static_cast<std::size_t>(r)] + S / 2 + jitter_y_m);
      s.truth.push_back(b);
      const double ex = b.long_m / 2 * std::abs(std::cos(b.yaw_rad)) + b.short_m / 2 * std::abs(std::sin(b.yaw_rad));
      const double ey = b.long_m / 2 * std::abs(std::sin(b.yaw_rad)) + b.short_m / 2 * std::abs(std::cos(b.yaw_rad));
      bx0 = std::min(bx0, b.center.x() - ex); bx1 = std::max(bx1, b.center.x() + ex);
      by0 = std::min(by0, b.center.y() - ey); by1 = std::max(by1, b.center.y() + ey);
    }
  }
  // Layer points on a pixel grid (random phase), only on box tops.
  std::vector<Eigen::Vector2f> points;
  const double ox = pitch_m * (u(rng) + 1) / 2, oy = pitch_m * (u(rng) + 1) / 2;
  for (double py = by0 - 0.01 + oy; py < by1 + 0.01; py += pitch_m) {
    for (double px = bx0 - 0.01 + ox; px < bx1 + 0.01; px += pitch_m) {
      const Eigen::Vector2d p(px, py);
      for (const auto& b : s.truth) {
        if (inside(b, p)) {
          points.emplace_back(static_cast<float>(px), static_cast<float>(py));
          break;
        }
      }
    }
  }
  // Seam raster: the share of each cell not covered by a box top (or covered by a patch),
  // zero within two cells of the outline (as build_seam_evidence does).
  const layout_test::Rect2d outline{bx0, by0, bx1, by1};
  auto seam_share = [&](const layout_test::SeamCell& cell) {
    const Eigen::Vector2d cell_max_m = cell.min_m + Eigen::Vector2d(pitch_m, pitch_m);
    if (!layout_test::inside_by(outline, 2 * pitch_m, cell.min_m, cell_max_m)) return 0.f;
    int open = 0;
    for (int sy = 0; sy < 4; ++sy) {
      for (int sx = 0; sx < 4; ++sx) {
        const Eigen::Vector2d p(cell.min_m.x() + (sx + 0.5) * pitch_m / 4,
                                cell.min_m.y() + (sy + 0.5) * pitch_m / 4);
        bool top = false;
        for (const auto& b : s.truth) top = top || inside(b, p);
        for (const auto& q : patches)
          top = top && !(p.x() >= q.x0 && p.x() <= q.x1 && p.y() >= q.y0 && p.y() <= q.y1);
        open += top ? 0 : 1;
      }
    }
    return static_cast<float>(open) / 16.f;
  };
  // Layer, seams and the search's answer (nominal boxes packed from the outline's lower-left
  // corner); the layer points from above.
  layout_test::RefineInput& input = s;
  input = layout_test::packed_block_input(outline, cols, rows, kFormats[0], {bx0 - 0.02, by0 - 0.02}, pitch_m,
                                          seam_share);
  s.layer.points_2d = std::move(points);
  return s;
}

struct Errors {
  double max_pos_m = 0, max_yaw_rad = 0;
};

Errors errors(const Scene& s, const LayoutResult& r) {
  Errors e;
  REQUIRE(r.boxes.size() == s.truth.size());
  for (std::size_t i = 0; i < s.truth.size(); ++i) {
    e.max_pos_m = std::max(e.max_pos_m, (r.boxes[i].center - s.truth[i].center).norm());
    e.max_yaw_rad = std::max(e.max_yaw_rad, std::abs(std::remainder(r.boxes[i].yaw_rad - s.truth[i].yaw_rad, M_PI)));
  }
  return e;
}

Errors refine_errors(const Scene& s) {
  LayoutParams params;
  return errors(s, refine_layout(s.found, s.layer, kFormats, &s.seams, params));
}

}  // namespace

TEST_CASE("refine: a block with seams of different widths reaches millimetres", "[refine]") {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 4; ++trial) {
    std::uniform_real_distribution<double> gap(0.004, 0.015);
    // The row gaps are drawn before the column gaps (the order gcc evaluated the arguments in).
    const std::vector<double> gaps_y{gap(rng), gap(rng)};
    const std::vector<double> gaps_x{gap(rng), gap(rng)};
    const Scene s = make_block(3, 3, gaps_x, gaps_y, 0.003, 0.002, 0.0, rng);
    const Errors before = errors(s, s.found);
    const Errors after = refine_errors(s);
    INFO("trial " << trial << " before " << before.max_pos_m * 1000 << " mm, after " << after.max_pos_m * 1000 << " mm");
    CHECK(before.max_pos_m > 0.006);  // the packed nominal grid is visibly off
    CHECK(after.max_pos_m < 0.0015);
  }
}

TEST_CASE("refine: interior box of a 3x3 block without outline edge is fitted to its seams", "[refine]") {
  std::mt19937 rng(9);
  const Scene s = make_block(3, 3, {0.012, 0.006}, {0.010, 0.008}, 0.002, 0.0, 0.0, rng);
  LayoutParams params;
  const LayoutResult r = refine_layout(s.found, s.layer, kFormats, &s.seams, params);
  // Box 4 is the centre box: all four sides are seams.
  CHECK((r.boxes[4].center - s.truth[4].center).norm() < 0.0015);
  CHECK(std::abs(r.boxes[4].long_m - s.truth[4].long_m) < 0.002);
  CHECK(std::abs(r.boxes[4].short_m - s.truth[4].short_m) < 0.002);
}

TEST_CASE("refine: per-box yaw follows the sides", "[refine]") {
  std::mt19937 rng(21);
  const double deg = M_PI / 180.0;
  const Scene s = make_block(3, 2, {0.010, 0.012}, {0.012}, 0.002, 0.001, 1.0 * deg, rng);
  const Errors after = refine_errors(s);
  double max_true_yaw = 0;
  for (const auto& b : s.truth) max_true_yaw = std::max(max_true_yaw, std::abs(b.yaw_rad));
  INFO("max true yaw " << max_true_yaw / deg << " deg, max error " << after.max_yaw_rad / deg << " deg");
  CHECK(max_true_yaw > 0.5 * deg);
  CHECK(after.max_yaw_rad < 0.25 * deg);
  CHECK(after.max_pos_m < 0.002);
}

TEST_CASE("refine: coarse pixels do not turn single boxes (yaw prior)", "[refine]") {
  // A 15 mm pixel footprint (a 176x132 camera at 2.5 m): each side's slope is only known to
  // a few tenths of a degree; the boxes are aligned in truth. The prior on a box's own turn
  // keeps every box closer to the truth than free per-box slopes do.
  const double deg = M_PI / 180.0;
  double worst_prior = 0, worst_free = 0;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed);
    const Scene s = make_block(3, 2, {0.010, 0.014}, {0.012}, 0.003, 0.002, 0.0, rng, {}, 0.015);
    LayoutParams params;
    worst_prior = std::max(worst_prior, errors(s, refine_layout(s.found, s.layer, kFormats, &s.seams, params)).max_yaw_rad);
    params.refine.yaw_sigma_deg = 10.0;
    worst_free = std::max(worst_free, errors(s, refine_layout(s.found, s.layer, kFormats, &s.seams, params)).max_yaw_rad);
  }
  INFO("worst yaw error with the prior " << worst_prior / deg << " deg, free " << worst_free / deg << " deg");
  CHECK(worst_prior < 0.25 * deg);
  CHECK(worst_free > 1.5 * worst_prior);
}

TEST_CASE("refine: an outline side far beyond the packed box is found at a coarse footprint", "[refine]") {
  // Two 8 mm gaps put the packed nominal grid's last box 16 mm short of its outline side, and
  // neither a seam raster nor a break in the points (12 mm footprint) shows them: that side is
  // the last box's only evidence. The points must be read a gap (2.5 footprints) beyond the
  // 30 mm window to see where they end.
  std::mt19937 rng(31);
  const Scene s = make_block(3, 1, {0.008, 0.008}, {}, 0.0, 0.0, 0.0, rng, {}, 0.012);
  const Errors before = errors(s, s.found);
  const Errors after = errors(s, refine_layout(s.found, s.layer, kFormats, nullptr, LayoutParams{}));
  INFO("before " << before.max_pos_m * 1000 << " mm, after " << after.max_pos_m * 1000 << " mm");
  CHECK(before.max_pos_m > 0.015);
  CHECK(after.max_pos_m < 0.005);
}

/// Four 400 x 300 cartons built 5 % large in a row, pressed together, 12 mm pixels; the search's
/// nominal boxes packed from the row's first end.
static Scene oversize_row(unsigned seed) {
  std::mt19937 rng(seed);
  return make_block(4, 1, {0.0, 0.0, 0.0}, {}, 0.0, 0.0, 0.0, rng, {}, 0.012, 1.05);
}

TEST_CASE("refine: a pressed row of cartons built over their format spreads over its outline", "[refine]") {
  // No seam seen: the search's last box lies 60 mm short of its outline side.
  const Scene s = oversize_row(41);
  const Errors before = errors(s, s.found);
  const Errors after = errors(s, refine_layout(s.found, s.layer, kFormats, nullptr, LayoutParams{}));
  INFO("before " << before.max_pos_m * 1000 << " mm, after " << after.max_pos_m * 1000 << " mm");
  CHECK(before.max_pos_m > 0.05);
  CHECK(after.max_pos_m < 0.008);
}

TEST_CASE("refine: a gap the fit opens where the points show carton top closes", "[refine]") {
  // The search's last box at the outline's far end: 60 mm between boxes 2 and 3 that no seam and
  // no missing point shows. The pair is pressed; the row's sizes grow instead.
  Scene s = oversize_row(43);
  s.found.boxes[3].center.x() = s.truth[3].center.x() + 0.5 * (s.truth[3].long_m - kFormats[0].long_m);
  const Errors before = errors(s, s.found);
  const LayoutResult refined = refine_layout(s.found, s.layer, kFormats, nullptr, LayoutParams{});
  const Errors after = errors(s, refined);
  INFO("before " << before.max_pos_m * 1000 << " mm, after " << after.max_pos_m * 1000 << " mm");
  CHECK(before.max_pos_m > 0.04);
  CHECK(after.max_pos_m < 0.008);
  for (const LayoutBox& b : refined.boxes) CHECK(b.long_m > 0.41);
}

TEST_CASE("refine: boxes pressed together (no seam) touch their neighbour at nominal size", "[refine]") {
  std::mt19937 rng(3);
  // Columns 0 and 1 pressed together, a 12 mm seam after column 1; sizes exactly nominal.
  const Scene s = make_block(3, 1, {0.0, 0.012}, {}, 0.0, 0.0, 0.0, rng);
  const Errors after = refine_errors(s);
  CHECK(after.max_pos_m < 0.002);
}

TEST_CASE("refine: labels and tape near box sides do not pull the sides", "[refine]") {
  std::mt19937 rng(17);
  // Seam-like patches on box tops: a label whose edge runs 15 mm inside a side along a third
  // of it, and a tape strip across the middle box.
  std::vector<Patch> patches{{0.385, 0.05, 0.40, 0.15}, {0.60, 0.0, 0.65, 0.30}};
  const Scene s = make_block(3, 1, {0.010, 0.010}, {}, 0.002, 0.0, 0.0, rng, patches);
  const Errors after = refine_errors(s);
  CHECK(after.max_pos_m < 0.002);
}

TEST_CASE("refine: robust edge line ignores outlier samples", "[refine]") {
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.001);
  std::vector<Eigen::Vector2d> samples;
  for (int k = 0; k < 100; ++k) {
    const double t = -0.2 + 0.004 * k;
    double p = 0.15 + 0.01 * t + noise(rng);
    if (k % 4 == 0) p -= 0.02;  // a quarter of the slices hit a label edge
    samples.emplace_back(t, p);
  }
  const layout_detail::EdgeLine line = layout_detail::fit_edge_line(samples, 0.0, 0.0005);
  REQUIRE(line.ok);
  CHECK(std::abs(line.offset_m - 0.15) < 0.0005);
  CHECK(std::abs(line.slope - 0.01) < 0.002);
  CHECK(line.inliers >= 70);
  CHECK(line.inliers <= 80);
}

TEST_CASE("refine: an edge line turned beyond any box is fitted flat", "[refine]") {
  // A seam side of a pinwheel's inner box at 176 x 132 (20 mm pixels), truly at -5.4 mm: nine
  // slices on the half of the side away from the box centre (t_ref -0.1 m; the rest of the seam
  // band is not seen), the first three walked on into the hole beyond the seam, the others
  // scattered by the pixel quantisation.
  const std::vector<double> p_mm{17.8, 16.2, 8.7, -5.4, 1.5, 4.5, -1.1, -6.3, -4.7};
  std::vector<Eigen::Vector2d> samples;
  for (std::size_t k = 0; k < p_mm.size(); ++k) samples.emplace_back(0.015 * static_cast<double>(k), 0.001 * p_mm[k]);
  const double t_ref = -0.1, truth = -0.0054;
  const layout_detail::EdgeLine free = layout_detail::fit_edge_line(samples, t_ref, 0.003, 8);
  REQUIRE(free.ok);
  CHECK(std::abs(free.slope) > std::tan(5.0 * M_PI / 180.0));
  CHECK(std::abs(free.offset_m - truth) > 0.02);  // the strays carried the side away
  const double max_slope = std::tan(5.0 * M_PI / 180.0);
  const layout_detail::EdgeLine flat = layout_detail::fit_edge_line(samples, t_ref, 0.003, 8, max_slope);
  REQUIRE(flat.ok);
  CHECK(flat.slope == 0.0);
  CHECK(std::isinf(flat.sigma_slope));  // no turn measured
  CHECK(std::abs(flat.offset_m - truth) < 0.01);  // within half a pixel
  // A side within the bound keeps its slope.
  std::vector<Eigen::Vector2d> turned;
  for (int k = 0; k < 12; ++k) turned.emplace_back(-0.1 + 0.02 * k, 0.001 + 0.05 * (-0.1 + 0.02 * k));
  const layout_detail::EdgeLine kept = layout_detail::fit_edge_line(turned, 0.0, 0.001, 5, max_slope);
  REQUIRE(kept.ok);
  CHECK(kept.slope == Approx(0.05).margin(1e-6));
}

TEST_CASE("refine: joint solve chains a pressed row to its measured ends", "[refine]") {
  using namespace layout_detail;
  // Three boxes in a row; only the outer sides are measured, the two seams are unseen.
  std::vector<JointBox> boxes(3);
  for (int i = 0; i < 3; ++i) {
    boxes[static_cast<std::size_t>(i)].center = Eigen::Vector2d(0.2 + 0.4 * i + 0.01, 0.15);
    boxes[static_cast<std::size_t>(i)].half = boxes[static_cast<std::size_t>(i)].half_nominal = Eigen::Vector2d(0.2, 0.15);
  }
  std::vector<SideObservation> sides{{0, 0, -1, 0.003, 0.0005}, {2, 0, 1, 1.203, 0.0005}};
  std::vector<Contact> contacts{{0, 1, 0, 0.001}, {1, 2, 0, 0.001}};
  solve_joint(boxes, sides, contacts, JointParams{});
  CHECK(boxes[0].center.x() == Approx(0.203).margin(0.0005));
  CHECK(boxes[1].center.x() == Approx(0.603).margin(0.0005));
  CHECK(boxes[2].center.x() == Approx(1.003).margin(0.0005));
  CHECK(boxes[1].half.x() == Approx(0.2).margin(0.0005));
}

TEST_CASE("refine: joint solve spreads a row over its ends when a misread seam calls one carton oversize",
          "[refine]") {
  using namespace layout_detail;
  // Three 400 mm cartons in a row, built 416 mm: the row's ends are measured 1248 mm apart. The
  // seam between boxes 1 and 2 is unseen (pressed); the one between boxes 0 and 1 is misread
  // 15 mm into box 1, loosely, and box 1's side of it is not seen. Read alone, box 0 is 430 mm,
  // over what a carton of the format is built; the row's ends and the batch say 416 mm. The fit
  // keeps every box inside the row's ends and the misread seam gives way.
  std::vector<JointBox> boxes(3);
  for (int i = 0; i < 3; ++i) {
    boxes[static_cast<std::size_t>(i)].center = Eigen::Vector2d(-0.416 + 0.416 * i, 0.0);
    boxes[static_cast<std::size_t>(i)].half = boxes[static_cast<std::size_t>(i)].half_nominal =
        Eigen::Vector2d(0.2, 0.15);
  }
  const std::vector<SideObservation> sides{
      {0, 0, -1, -0.624, 0.0009}, {0, 0, 1, -0.194, 0.0049}, {2, 0, 1, 0.624, 0.0011}};
  const std::vector<Contact> contacts{{1, 2, 0, 0.002}};
  const std::vector<Contact> neighbours{{0, 1, 0, 0.002}, {1, 2, 0, 0.002}};
  solve_joint(boxes, sides, contacts, JointParams{}, neighbours);
  for (int i = 0; i < 3; ++i) {
    INFO("box " << i << " centre " << boxes[static_cast<std::size_t>(i)].center.x() * 1000 << " mm, half "
                << boxes[static_cast<std::size_t>(i)].half.x() * 1000 << " mm");
    CHECK(boxes[static_cast<std::size_t>(i)].center.x() == Approx(-0.416 + 0.416 * i).margin(0.004));
  }
  CHECK(boxes[2].center.x() + boxes[2].half.x() == Approx(0.624).margin(0.002));
}

TEST_CASE("refine: joint solve sizes a turned carton like its batch measured along the other axis",
          "[refine]") {
  using namespace layout_detail;
  // Box 0 stands with its short side along y, both y sides measured: 318 mm. Box 1 is turned
  // (short side along x) with only its left side seen. The batch's short side is 318 mm, so
  // box 1's centre lies 159 mm from its left side, not the nominal 150.
  std::vector<JointBox> boxes(2);
  boxes[0].center = Eigen::Vector2d(0.2, 0.15);
  boxes[0].half = boxes[0].half_nominal = Eigen::Vector2d(0.2, 0.15);
  boxes[1].center = Eigen::Vector2d(0.6, 0.2);
  boxes[1].half = boxes[1].half_nominal = Eigen::Vector2d(0.15, 0.2);
  const std::vector<SideObservation> sides{
      {0, 1, -1, -0.009, 0.0005}, {0, 1, 1, 0.309, 0.0005}, {0, 0, -1, 0.0, 0.0005}, {0, 0, 1, 0.4, 0.0005},
      {1, 0, -1, 0.45, 0.0005},   {1, 1, -1, 0.0, 0.0005},  {1, 1, 1, 0.4, 0.0005}};
  solve_joint(boxes, sides, {}, JointParams{});
  CHECK(boxes[0].half.y() == Approx(0.159).margin(0.0005));
  CHECK(boxes[1].half.x() == Approx(0.159).margin(0.001));
  CHECK(boxes[1].center.x() == Approx(0.609).margin(0.001));
}

TEST_CASE("refine: joint solve keeps solid neighbours from overlapping", "[refine]") {
  using namespace layout_detail;
  // Two boxes in a row, all four sides measured; box 0's right side is misread 15 mm into
  // box 1 (a seam band beyond the real seam), loosely. Alone, the fit lets box 0 reach into
  // box 1; as neighbours, box 0 stops where box 1's well-measured side is.
  std::vector<JointBox> boxes(2);
  for (int i = 0; i < 2; ++i) {
    boxes[static_cast<std::size_t>(i)].center = Eigen::Vector2d(0.2 + 0.405 * i, 0.15);
    boxes[static_cast<std::size_t>(i)].half = boxes[static_cast<std::size_t>(i)].half_nominal = Eigen::Vector2d(0.2, 0.15);
  }
  const std::vector<SideObservation> sides{
      {0, 0, -1, 0.0, 0.0005}, {0, 0, 1, 0.420, 0.003}, {1, 0, -1, 0.405, 0.0005}, {1, 0, 1, 0.805, 0.0005}};
  const std::vector<Contact> neighbours{{0, 1, 0, 0.001}};
  auto gap_m = [](const std::vector<JointBox>& b) { return (b[1].center.x() - b[1].half.x()) - (b[0].center.x() + b[0].half.x()); };
  std::vector<JointBox> alone = boxes, solid = boxes;
  solve_joint(alone, sides, {}, JointParams{});
  solve_joint(solid, sides, {}, JointParams{}, neighbours);
  INFO("gap alone " << gap_m(alone) * 1000 << " mm, as neighbours " << gap_m(solid) * 1000 << " mm");
  CHECK(gap_m(alone) < -0.005);
  CHECK(gap_m(solid) > -0.0005);
  // The well-measured box keeps (nearly) its place: box 0's misread side gives way.
  CHECK(solid[1].center.x() == Approx(0.605).margin(0.002));
  CHECK(solid[0].center.x() + solid[0].half.x() < alone[0].center.x() + alone[0].half.x() - 0.002);
}

TEST_CASE("refine: a component without evidence of its own turns to its layer's orientation", "[refine]") {
  // A 3x2 block and, 1.5 m away, a lone box of the same aligned layer whose outline the search
  // read 1.5 deg off and whose points are lost (no side can be measured): separate components
  // stand on one pallet pattern, so it takes the block's measured orientation.
  const double deg = M_PI / 180.0;
  std::mt19937 rng(4);
  Scene s = make_block(3, 2, {0.010, 0.010}, {0.010}, 0.002, 0.0, 0.0, rng, {}, 0.005);
  const Scene lone = make_block(1, 1, {}, {}, 0.0, 0.0, 0.0, rng, {}, 0.005);
  const Eigen::Vector2d offset(1.5, 0.0);
  s.layer.polygons.push_back(lone.layer.polygons.front());
  for (auto& v : s.layer.polygons.back().outer) v += offset;
  LayoutBox b = lone.found.boxes.front();
  b.center += offset;
  b.yaw_rad += 1.5 * deg;
  b.component = 1;
  s.found.boxes.push_back(b);
  const LayoutResult r = refine_layout(s.found, s.layer, kFormats, &s.seams, LayoutParams{});
  REQUIRE(r.boxes.size() == 7);
  const double lone_error = std::abs(std::remainder(r.boxes.back().yaw_rad, M_PI / 2));
  INFO("lone box yaw error " << lone_error / deg << " deg (search 1.5 deg)");
  CHECK(lone_error < 0.1 * deg);
  // The block itself keeps its own (right) orientation.
  for (std::size_t i = 0; i + 1 < r.boxes.size(); ++i)
    CHECK(std::abs(std::remainder(r.boxes[i].yaw_rad, M_PI / 2)) < 0.1 * deg);
}
