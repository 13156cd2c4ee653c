// Scene building: patterns fit the pallet without overlaps, partial layers, camera placement.
#include <map>
#include <set>
#include <tuple>

#include <catch2/catch.hpp>

#include "../../src/sim/sim_internal.hpp"
#include "sim_test_util.hpp"

using namespace palletd;
using namespace palletd::sim;

namespace {

const std::vector<PatternFamily> kPatterns{PatternFamily::kBlock,    PatternFamily::kInterlock, PatternFamily::kBrick,
                                           PatternFamily::kPinwheel, PatternFamily::kChimney,   PatternFamily::kMixed};

std::vector<std::vector<BoxFormatSpec>> format_sets() {
  std::vector<std::vector<BoxFormatSpec>> sets;
  for (const char* f : {"600x400", "400x300", "300x200", "315x232", "200x150", "500x290"})
    sets.push_back({*parse_format(f)});
  return sets;
}

}  // namespace

TEST_CASE("parse_format reads LONGxSHORT and LONGxSHORTxHEIGHT and rejects garbage") {
  auto f = parse_format("232x315x180");
  REQUIRE(f.ok());
  CHECK(f->name == "315x232");
  CHECK(f->long_m == Approx(0.315));
  CHECK(f->short_m == Approx(0.232));
  CHECK(f->height_m == Approx(0.180));
  CHECK_FALSE(parse_format("315").ok());
  CHECK_FALSE(parse_format("axb").ok());
  CHECK_FALSE(parse_format("315x-2").ok());
}

TEST_CASE("patterns have no overlapping boxes and stay within the pallet") {
  const SensorProfile profile = *profile_by_name("o3d303");
  int scenes = 0;
  for (PalletKind pallet : {PalletKind::kEur1200x800, PalletKind::kIndustrial1200x1000, PalletKind::kNone})
    for (PatternFamily pattern : kPatterns)
      for (const auto& formats : format_sets())
        for (std::uint64_t seed = 1; seed <= 3; ++seed) {
          ScenarioOptions o;
          o.pallet = pallet;
          o.pattern = pattern;
          o.formats = formats;
          o.gap_max_m = seed == 1 ? 0.0 : 0.015;
          auto scene = make_scene(o, profile, seed * 7919);
          REQUIRE(scene.ok());
          ++scenes;
          std::map<long, std::vector<const SimBox*>> layers;  // by bottom height [0.1 mm]
          for (const SimBox& b : scene->boxes)
            if (b.format_index >= 0) layers[std::lround(b.bottom_z_m * 1e4)].push_back(&b);
          REQUIRE(layers.size() >= 2);
          for (const auto& [z, boxes] : layers) {
            for (std::size_t i = 0; i < boxes.size(); ++i) {
              for (const auto& c : detail::footprint_corners(boxes[i]->center, boxes[i]->yaw_rad, boxes[i]->long_m,
                                                             boxes[i]->short_m)) {
                INFO(to_string(pattern) << " " << formats[0].name << " on " << to_string(pallet) << " seed " << seed);
                CHECK(std::abs(c.x()) <= 0.5 * scene->pallet_long_m + 1e-9);
                CHECK(std::abs(c.y()) <= 0.5 * scene->pallet_short_m + 1e-9);
              }
              for (std::size_t j = i + 1; j < boxes.size(); ++j) {
                INFO(to_string(pattern) << " " << formats[0].name << " boxes " << i << ", " << j);
                CHECK_FALSE(detail::footprints_overlap(*boxes[i], *boxes[j]));
              }
            }
          }
        }
  CHECK(scenes == 3 * 6 * 6 * 3);
}

TEST_CASE("footprints_overlap detects overlap and accepts touching boxes") {
  SimBox a, b;
  a.long_m = b.long_m = 0.4;
  a.short_m = b.short_m = 0.3;
  b.center = Eigen::Vector2d(0.4, 0.0);  // touching along x
  CHECK_FALSE(detail::footprints_overlap(a, b));
  b.center.x() = 0.39;
  CHECK(detail::footprints_overlap(a, b));
  b.center = Eigen::Vector2d(0.36, 0.26);
  b.yaw_rad = 0.785;  // a rotated box reaching into a's corner
  CHECK(detail::footprints_overlap(a, b));
}

TEST_CASE("pattern families differ in their layouts") {
  detail::Rng rng(5);
  const auto f315 = std::vector<BoxFormatSpec>{*parse_format("315x232")};
  const auto block = detail::make_pattern(PatternFamily::kBlock, f315, 1.2, 0.8, rng);
  const auto interlock = detail::make_pattern(PatternFamily::kInterlock, f315, 1.2, 0.8, rng);
  const auto pinwheel = detail::make_pattern(PatternFamily::kPinwheel, f315, 1.2, 0.8, rng);
  auto orientations = [](const std::vector<detail::PlacedBox>& boxes) {
    std::set<long> yaws;
    for (const auto& b : boxes) yaws.insert(std::lround(std::fmod(b.yaw_rad + 2.0 * detail::kPi, detail::kPi) * 100.0));
    return yaws.size();
  };
  CHECK(block.size() == 10);  // 5 x 2 of 315x232 (short side along 1200) on 1200x800
  CHECK(orientations(block) == 1);
  CHECK(interlock.size() >= block.size());
  CHECK(orientations(interlock) == 2);
  CHECK(orientations(pinwheel) == 2);
  // Brick: neighbouring rows have their seams offset.
  const auto brick = detail::make_pattern(PatternFamily::kBrick, f315, 1.2, 0.8, rng);
  std::map<long, std::vector<double>> rows;
  for (const auto& b : brick) rows[std::lround(b.center.y() * 1000.0)].push_back(b.center.x());
  REQUIRE(rows.size() >= 2);
  const double x0 = *std::min_element(rows.begin()->second.begin(), rows.begin()->second.end());
  const double x1 = *std::min_element(std::next(rows.begin())->second.begin(), std::next(rows.begin())->second.end());
  const double offset = std::abs(x1 - x0);
  CHECK((std::abs(offset - 0.5 * 0.315) < 1e-9 || std::abs(offset - 0.5 * 0.232) < 1e-9));
  // Mixed: both formats present.
  const auto mixed = detail::make_pattern(PatternFamily::kMixed, {*parse_format("600x400"), *parse_format("400x300")}, 1.2,
                                          0.8, rng);
  std::set<int> formats;
  for (const auto& b : mixed) formats.insert(b.format);
  CHECK(formats.size() == 2);
}

namespace {

/// Largest uncovered region [m^2] enclosed by the layout (not connected to the bounding box border).
double largest_enclosed_hole(const std::vector<detail::PlacedBox>& boxes, const BoxFormatSpec& f) {
  const double cell = 0.005;
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (const auto& b : boxes)
    for (const auto& c : detail::footprint_corners(b.center, b.yaw_rad, f.long_m, f.short_m)) {
      lo = lo.cwiseMin(c);
      hi = hi.cwiseMax(c);
    }
  const int nx = static_cast<int>((hi.x() - lo.x()) / cell) + 1, ny = static_cast<int>((hi.y() - lo.y()) / cell) + 1;
  std::vector<int> grid(static_cast<std::size_t>(nx * ny), 0);  // 0 free, 1 covered, 2 visited
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const Eigen::Vector2d p = lo + cell * Eigen::Vector2d(i + 0.5, j + 0.5);
      for (const auto& b : boxes) {
        const Eigen::Vector2d d = p - b.center;
        const double a = std::abs(d.x() * std::cos(b.yaw_rad) + d.y() * std::sin(b.yaw_rad));
        const double c = std::abs(-d.x() * std::sin(b.yaw_rad) + d.y() * std::cos(b.yaw_rad));
        if (a < 0.5 * f.long_m && c < 0.5 * f.short_m) grid[static_cast<std::size_t>(j * nx + i)] = 1;
      }
    }
  double best = 0.0;
  for (int start = 0; start < nx * ny; ++start) {
    if (grid[static_cast<std::size_t>(start)] != 0) continue;
    std::vector<int> stack{start};
    grid[static_cast<std::size_t>(start)] = 2;
    int count = 0;
    bool border = false;
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      ++count;
      const int i = k % nx, j = k / nx;
      if (i == 0 || j == 0 || i == nx - 1 || j == ny - 1) border = true;
      const int next[4][2] = {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}};
      for (const auto& q : next) {
        if (q[0] < 0 || q[1] < 0 || q[0] >= nx || q[1] >= ny) continue;
        const int m = q[1] * nx + q[0];
        if (grid[static_cast<std::size_t>(m)] != 0) continue;
        grid[static_cast<std::size_t>(m)] = 2;
        stack.push_back(m);
      }
    }
    if (!border) best = std::max(best, count * cell * cell);
  }
  return best;
}

}  // namespace

TEST_CASE("chimney encloses a larger central hole than the pinwheel") {
  // Where the pallet leaves room for both (a chimney hole is 40-100 % of the short side).
  const std::vector<std::pair<std::string, double>> cases{{"315x232", 0.8}, {"315x232", 1.0}, {"400x300", 1.0}};
  for (const auto& [name, pallet_short] : cases) {
    detail::Rng rng(3);
    const BoxFormatSpec f = *parse_format(name);
    const auto chimney = detail::make_pattern(PatternFamily::kChimney, {f}, 1.2, pallet_short, rng);
    const auto pinwheel = detail::make_pattern(PatternFamily::kPinwheel, {f}, 1.2, pallet_short, rng);
    const double hole = largest_enclosed_hole(chimney, f);
    INFO(name << " on 1200x" << pallet_short * 1000);
    CHECK(hole < f.short_m * f.short_m);
    CHECK(hole >= std::pow(0.4 * f.short_m - 0.01, 2));
    CHECK(largest_enclosed_hole(pinwheel, f) < hole);
  }
}

TEST_CASE("fill keeps the requested share of the top layer, down to one box") {
  const SensorProfile profile = *profile_by_name("o3d303");
  for (RemovalMode mode : {RemovalMode::kRows, RemovalMode::kColumns, RemovalMode::kCorner, RemovalMode::kRandom,
                           RemovalMode::kHoles, RemovalMode::kClusters}) {
    ScenarioOptions o;
    o.pattern = PatternFamily::kBlock;
    o.formats = {*parse_format("300x200")};  // 16 boxes on 1200x800
    o.removal = mode;
    o.fill = 1.0;
    const std::size_t full = make_scene(o, profile, 11)->top_layer.size();
    CHECK(full == 16);
    o.fill = 0.5;
    CHECK(make_scene(o, profile, 11)->top_layer.size() == 8);
    o.fill = 0.0;
    CHECK(make_scene(o, profile, 11)->top_layer.size() == 1);
  }
}

TEST_CASE("clusters removal leaves separate groups and holes removal keeps the outline") {
  const SensorProfile profile = *profile_by_name("o3d303");
  ScenarioOptions o;
  o.formats = {*parse_format("300x200")};
  o.fill = 0.5;
  o.removal = RemovalMode::kClusters;
  o.jitter_m = 0.0;
  o.jitter_deg = 0.0;
  o.gap_max_m = 0.0;
  o.layer_offset_max_m = 0.0;
  auto scene = make_scene(o, profile, 4);
  REQUIRE(scene.ok());
  // The middle band is gone: no box centre near the layer's centre line along one axis.
  bool band_x = true, band_y = true;
  for (std::size_t i : scene->top_layer) {
    const SimBox& b = scene->boxes[i];
    if (std::abs(b.center.x()) < 0.2) band_x = false;
    if (std::abs(b.center.y()) < 0.15) band_y = false;
  }
  CHECK((band_x || band_y));

  o.removal = RemovalMode::kHoles;
  o.fill = 0.75;  // 4 interior boxes of 16 removed
  scene = make_scene(o, profile, 4);
  REQUIRE(scene.ok());
  for (std::size_t i : scene->top_layer) {
    const SimBox& b = scene->boxes[i];
    const bool outline = std::abs(std::abs(b.center.x()) - 0.45) < 0.01 || std::abs(std::abs(b.center.y()) - 0.3) < 0.01;
    CHECK(outline);
  }
}

TEST_CASE("truth boxes lie inside the image") {
  for (const std::string& name : profile_names()) {
    const SensorProfile profile = *profile_by_name(name);
    for (PatternFamily pattern : kPatterns)
      for (std::uint64_t seed = 1; seed <= 4; ++seed) {
        ScenarioOptions o;
        o.pattern = pattern;
        o.pallet = seed % 2 == 0 ? PalletKind::kIndustrial1200x1000 : PalletKind::kEur1200x800;
        auto scene = make_scene(o, profile, seed);
        REQUIRE(scene.ok());
        const Truth truth = make_truth(*scene);
        REQUIRE_FALSE(truth.boxes.empty());
        for (const TruthBox& box : truth.boxes) {
          for (const Eigen::Vector3d& c : truth_corners(box)) {
            Eigen::Vector2d px;
            REQUIRE(project(profile.intrinsics, c, px));
            INFO(name << " " << to_string(pattern) << " seed " << seed);
            CHECK(px.x() >= 0.0);
            CHECK(px.y() >= 0.0);
            CHECK(px.x() <= profile.intrinsics.width - 1.0);
            CHECK(px.y() <= profile.intrinsics.height - 1.0);
          }
          // Normal toward the camera, unit long axis in the plane.
          CHECK(box.normal.dot(box.center) < 0.0);
          CHECK(box.long_axis.norm() == Approx(1.0));
          CHECK(std::abs(box.long_axis.dot(box.normal)) < 1e-9);
          CHECK(std::abs(truth.layer_plane.signed_distance(box.center)) < 0.0015);
        }
        // Camera 1.2 - 3.0 m above the top layer, tilt at most 30 degrees.
        const double height = truth.layer_plane.d;
        CHECK(height >= 1.2 - 1e-9);
        CHECK(height <= 3.0 + 1e-9);
        CHECK(-truth.layer_plane.normal.z() >= std::cos(30.0 * detail::kPi / 180.0) - 1e-9);
      }
  }
}

TEST_CASE("a set shows every pattern on every profile in every scene once per round") {
  const std::size_t patterns = 6, profiles = 6, scenes = 5, round = patterns * profiles * scenes;
  const auto shown = detail::frame_combinations(patterns, profiles, scenes, 90881, 2 * round + 7);
  REQUIRE(shown.size() == 2 * round + 7);
  for (std::size_t r = 0; r < 2; ++r) {
    std::set<std::tuple<std::size_t, std::size_t, std::size_t>> seen;
    for (std::size_t k = r * round; k < (r + 1) * round; ++k) {
      const detail::Combination& c = shown[k];
      REQUIRE(c.pattern < patterns);
      REQUIRE(c.profile < profiles);
      REQUIRE(c.scene < scenes);
      seen.insert({c.pattern, c.profile, c.scene});
    }
    CHECK(seen.size() == round);
  }
  // The k-th pattern is not tied to the k-th profile within the first few frames either.
  std::set<std::size_t> profiles_of_block;
  for (std::size_t k = 0; k < 60; ++k) {
    if (shown[k].pattern == 0) profiles_of_block.insert(shown[k].profile);
  }
  CHECK(profiles_of_block.size() >= 3);
  // The order is the seed's: the same seed repeats it, another seed changes it.
  const auto again = detail::frame_combinations(patterns, profiles, scenes, 90881, 40);
  const auto other = detail::frame_combinations(patterns, profiles, scenes, 90882, 40);
  std::size_t same = 0, differ = 0;
  for (std::size_t k = 0; k < 40; ++k) {
    same += again[k].pattern == shown[k].pattern && again[k].profile == shown[k].profile &&
            again[k].scene == shown[k].scene;
    differ += other[k].pattern != shown[k].pattern || other[k].profile != shown[k].profile ||
              other[k].scene != shown[k].scene;
  }
  CHECK(same == 40);
  CHECK(differ > 20);
}
