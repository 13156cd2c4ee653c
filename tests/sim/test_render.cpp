// Rendering: analytic planes, truth re-projection, noise per profile, determinism.
#include <catch2/catch.hpp>

#include <cmath>

#include "sim_test_util.hpp"

using namespace palletd;
using namespace palletd::sim;

namespace {

double depth_m(const Frame& f, std::size_t i) { return f.depth[i] * f.depth_scale_m; }

/// Analytic Z of the floor (z = 0 in the world) seen through pixel (u, v).
double floor_z(const Scene& s, const Intrinsics& k, double u, double v) {
  const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
  const Eigen::Vector3d d = s.T_world_camera.linear() * ray;
  return -s.T_world_camera.translation().z() / d.z();
}

struct Stats {
  double mean = 0.0, stddev = 0.0;
  std::size_t count = 0;
};

Stats stats(const std::vector<double>& x) {
  Stats s;
  s.count = x.size();
  for (double v : x) s.mean += v;
  s.mean /= static_cast<double>(x.size());
  for (double v : x) s.stddev += (v - s.mean) * (v - s.mean);
  s.stddev = std::sqrt(s.stddev / static_cast<double>(x.size() - 1));
  return s;
}

/// Point-in-convex-quad test with a margin [px] (positive margin: well inside).
bool inside_quad(const std::vector<Eigen::Vector2d>& q, const Eigen::Vector2d& p, double margin) {
  double area2 = 0.0;  // orientation of the quad in the image
  for (std::size_t i = 0; i < 4; ++i) area2 += q[i].x() * q[(i + 1) % 4].y() - q[(i + 1) % 4].x() * q[i].y();
  const double sign = area2 > 0.0 ? 1.0 : -1.0;
  for (std::size_t i = 0; i < 4; ++i) {
    const Eigen::Vector2d a = q[i], b = q[(i + 1) % 4];
    const Eigen::Vector2d e = b - a;
    const double cross = (e.x() * (p.y() - a.y()) - e.y() * (p.x() - a.x())) / e.norm();
    if (cross * sign < margin) return false;
  }
  return true;
}

}  // namespace

TEST_CASE("a rendered plane matches its analytic depth within the noise") {
  for (const std::string& name : {std::string("o3d303"), std::string("blaze101"), std::string("xtion")}) {
    const SensorProfile p = *profile_by_name(name);
    const Scene scene = test::floor_scene(2.2, 20.0, 0.5);
    const SimulatedFrame sim = render(scene, p, 42);
    const Intrinsics& k = p.intrinsics;
    std::vector<double> normalised;
    std::size_t valid = 0;
    for (int v = 0; v < k.height; ++v)
      for (int u = 0; u < k.width; ++u) {
        const std::size_t i = static_cast<std::size_t>(v * k.width + u);
        if (sim.frame.depth[i] == 0) continue;
        ++valid;
        const double z = floor_z(scene, k, u, v);
        const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
        double sigma = 0.0;
        if (p.kind == SensorKind::kTimeOfFlight) {
          // sigma along the ray ~ r / sqrt(rho cos), projected onto Z.
          const double r = z * ray.norm();
          const Eigen::Vector3d d = (scene.T_world_camera.linear() * ray).normalized();
          const double cos_inc = -d.z();
          sigma = p.tof_sigma_2m_m * (r / 2.0) / std::sqrt(0.5 * cos_inc / 0.5) / ray.norm();
        } else {
          const double q = z * z * 0.125 / (k.fx * 0.075);  // disparity step 1/8 px, baseline 75 mm
          sigma = std::sqrt(std::pow(0.0012 + 0.0019 * (z - 0.4) * (z - 0.4), 2) + q * q / 12.0);
        }
        sigma = std::sqrt(sigma * sigma + p.depth_scale_m * p.depth_scale_m / 12.0);
        normalised.push_back((depth_m(sim.frame, i) - z) / sigma);
      }
    const double n = static_cast<double>(sim.frame.depth.size());
    INFO(name);
    CHECK(static_cast<double>(valid) / n > 0.95);  // dropouts only (1-3 %)
    CHECK(static_cast<double>(valid) / n < 0.995);
    const Stats s = stats(normalised);
    CHECK(std::abs(s.mean) < 0.1);
    CHECK(s.stddev > 0.85);
    CHECK(s.stddev < 1.15);
  }
}

TEST_CASE("each profile's measured noise at 2 m matches its model") {
  for (const std::string& name : profile_names()) {
    const SensorProfile p = *profile_by_name(name);
    const Scene scene = test::floor_scene(2.0, 0.0, 0.5);
    const Intrinsics& k = p.intrinsics;
    std::vector<double> residual;
    for (std::uint64_t seed = 1; seed <= 2; ++seed) {
      const SimulatedFrame sim = render(scene, p, seed);
      for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
          const double x = (u - k.cx) / k.fx, y = (v - k.cy) / k.fy;
          if (x * x + y * y > 0.01) continue;  // central pixels: range ~ Z, normal incidence
          const std::size_t i = static_cast<std::size_t>(v * k.width + u);
          if (sim.frame.depth[i] != 0) residual.push_back(depth_m(sim.frame, i) - 2.0);
        }
    }
    // The models, written out from docs/simulator.md (with quantisation as uniform noise).
    double model = 0.0;
    if (p.kind == SensorKind::kTimeOfFlight) {
      model = p.tof_sigma_2m_m;  // reference reflectance 0.5 at 2 m
    } else if (p.kind == SensorKind::kActiveStereo) {
      model = 4.0 * p.stereo_sigma_px / (k.fx * p.sl_baseline_m);  // z^2 sigma_d / (fx b), no disparity steps
    } else {
      const double nguyen = 0.0012 + 0.0019 * (2.0 - 0.4) * (2.0 - 0.4);
      const double q = 4.0 * p.sl_disparity_step_px / (k.fx * p.sl_baseline_m);
      model = std::sqrt(nguyen * nguyen + q * q / 12.0);
    }
    model = std::sqrt(model * model + p.depth_scale_m * p.depth_scale_m / 12.0);
    const Stats s = stats(residual);
    INFO(name << ": measured " << s.stddev * 1000.0 << " mm, model " << model * 1000.0 << " mm, n " << s.count);
    REQUIRE(s.count > 500);
    CHECK(s.stddev > 0.85 * model);
    CHECK(s.stddev < 1.15 * model);
    CHECK(std::abs(s.mean) < 0.2 * model);
  }
}

TEST_CASE("a noise-free frame's truth boxes re-project exactly onto the rendered top faces") {
  for (PatternFamily pattern : {PatternFamily::kBlock, PatternFamily::kPinwheel, PatternFamily::kMixed}) {
    const SensorProfile p = *profile_by_name("blaze101");
    ScenarioOptions o = test::ideal_boxes(pattern);
    o.fill = 0.7;
    o.removal = RemovalMode::kRandom;
    const Scene scene = *make_scene(o, p, 17);
    const SimulatedFrame sim = render(scene, p, 17, test::noise_free());
    const Intrinsics& k = p.intrinsics;
    std::vector<std::vector<Eigen::Vector2d>> quads;
    for (const TruthBox& box : sim.truth.boxes) {
      std::vector<Eigen::Vector2d> q;
      for (const Eigen::Vector3d& c : truth_corners(box)) {
        Eigen::Vector2d px;
        REQUIRE(project(k, c, px));
        q.push_back(px);
      }
      quads.push_back(q);
    }
    const Plane& plane = sim.truth.layer_plane;
    std::size_t inside = 0, outside = 0, wrong_inside = 0, wrong_outside = 0;
    for (int v = 0; v < k.height; ++v)
      for (int u = 0; u < k.width; ++u) {
        const std::size_t i = static_cast<std::size_t>(v * k.width + u);
        const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
        const double plane_z = -plane.d / plane.normal.dot(ray);
        const bool on_plane = sim.frame.depth[i] != 0 && std::abs(depth_m(sim.frame, i) - plane_z) < 0.0006;
        bool in = false, near = false;
        for (const auto& q : quads) {
          in = in || inside_quad(q, Eigen::Vector2d(u, v), 0.75);
          near = near || inside_quad(q, Eigen::Vector2d(u, v), -0.75);
        }
        if (in) {
          ++inside;
          if (!on_plane) ++wrong_inside;
        } else if (!near) {
          ++outside;
          if (on_plane) ++wrong_outside;
        }
      }
    INFO(to_string(pattern) << ": " << inside << " pixels inside, " << outside << " outside");
    CHECK(inside > 5000);
    CHECK(outside > 5000);
    CHECK(wrong_inside == 0);
    CHECK(wrong_outside == 0);
  }
}

TEST_CASE("seams between touching boxes show as a narrow depth dip and a darker line") {
  const SensorProfile p = *profile_by_name("helios2");
  ScenarioOptions o;
  o.formats = {*parse_format("600x400")};
  o.gap_max_m = 0.0;
  o.jitter_m = 0.0;
  o.jitter_deg = 0.0;
  o.bulge_max_m = 0.0;
  o.bevel_m = 0.004;
  o.tape_probability = 0.0;
  o.label_probability = 0.0;
  o.layer_offset_max_m = 0.0;
  o.tilt_max_deg = 0.0;
  o.height_min_m = o.height_max_m = 1.5;
  Scene scene = *make_scene(o, p, 5);
  for (SimBox& b : scene.boxes) b.reflectance = 0.5;
  const SimulatedFrame sim = render(scene, p, 5, test::noise_free());
  // Walk across the seam between two boxes of the layer along the line joining their centres.
  const Eigen::Isometry3d T_camera_world = scene.T_world_camera.inverse();
  const SimBox& a = scene.boxes[scene.top_layer[0]];
  const SimBox* b = nullptr;
  for (std::size_t idx : scene.top_layer) {
    const SimBox& c = scene.boxes[idx];
    const double dist = (c.center - a.center).norm();
    if (dist > 0.39 && dist < 0.41) b = &c;
  }
  REQUIRE(b != nullptr);
  double face_z = 0.0, seam_z = 0.0, face_i = 0.0, seam_i = 1e9;
  for (int step = 0; step <= 200; ++step) {
    const Eigen::Vector2d q = a.center + (b->center - a.center) * (step / 200.0);
    Eigen::Vector2d px;
    REQUIRE(project(p.intrinsics, T_camera_world * Eigen::Vector3d(q.x(), q.y(), a.top_z_m), px));
    const std::size_t i = static_cast<std::size_t>(std::lround(px.y()) * p.intrinsics.width + std::lround(px.x()));
    const double z = depth_m(sim.frame, i);
    if (step == 50) {
      face_z = z;
      face_i = sim.frame.intensity[i];
    }
    if (step > 80 && step < 120) {
      seam_z = std::max(seam_z, z);
      seam_i = std::min(seam_i, static_cast<double>(sim.frame.intensity[i]));
    }
  }
  CHECK(seam_z - face_z > 0.001);  // a dip of a few millimetres
  CHECK(seam_z - face_z < 0.006);
  CHECK(seam_i < 0.9 * face_i);
}

TEST_CASE("supersampling makes mixed pixels at depth edges for ToF, not for structured light") {
  // One box right under a camera that looks straight down: no side face is visible, so depths
  // between the box top and the floor can only come from mixing.
  Scene scene = test::floor_scene(1.5, 0.0, 0.3);
  SimBox box;
  box.center = Eigen::Vector2d(0.013, -0.021);  // edges oblique to the pixel grid
  box.yaw_rad = 0.3;
  box.long_m = 0.6;
  box.short_m = 0.4;
  box.top_z_m = 0.25;
  box.format = "600x400";
  box.format_index = 0;
  scene.boxes.push_back(box);
  scene.top_layer.push_back(0);
  scene.top_z_m = 0.25;
  auto count_between = [&](const std::string& name) {
    const SensorProfile p = *profile_by_name(name);
    RenderOptions r = test::noise_free();
    r.supersampling = 0;  // the profile's
    const SimulatedFrame sim = render(scene, p, 8, r);
    std::size_t between = 0;
    for (std::size_t i = 0; i < sim.frame.depth.size(); ++i) {
      const double z = depth_m(sim.frame, i);
      if (z > 1.25 + 0.01 && z < 1.5 - 0.01) ++between;
    }
    return between;
  };
  CHECK(count_between("o3d303") > 100);
  CHECK(count_between("helios2") > 100);
  CHECK(count_between("xtion") == 0);
}

TEST_CASE("the same seed gives identical frames, another seed another frame") {
  SetOptions set;
  set.count = 3;
  set.seed = 99;
  set.fill_min = 0.4;
  set.fill_max = 1.0;
  set.profiles = {"o3d303", "xtion", "o3d303-small"};  // ToF, the projector's random pattern, small
  auto first = generate_set(set);
  auto second = generate_set(set);
  REQUIRE(first.ok());
  REQUIRE(second.ok());
  REQUIRE(first->size() == 3);
  for (std::size_t i = 0; i < 3; ++i) {
    const SimulatedFrame& a = (*first)[i];
    const SimulatedFrame& b = (*second)[i];
    CHECK(a.name == b.name);
    CHECK(a.frame.depth == b.frame.depth);
    CHECK(a.frame.intensity == b.frame.intensity);
    REQUIRE(a.truth.boxes.size() == b.truth.boxes.size());
    for (std::size_t j = 0; j < a.truth.boxes.size(); ++j) CHECK(a.truth.boxes[j].center == b.truth.boxes[j].center);
  }
  set.seed = 100;
  set.count = 1;  // the first frame of another seed is enough
  auto third = generate_set(set);
  REQUIRE(third.ok());
  CHECK((*third)[0].frame.depth != (*first)[0].frame.depth);
}

TEST_CASE("structured light leaves projector shadow bands beside boxes") {
  ScenarioOptions o;
  o.fill = 0.3;
  o.tilt_max_deg = 0.0;
  o.height_min_m = o.height_max_m = 1.3;
  const SensorProfile xtion = *profile_by_name("xtion");
  const Scene scene = *make_scene(o, xtion, 3);
  RenderOptions r;
  r.noise = false;
  const SimulatedFrame sim = render(scene, xtion, 3, r);
  // Runs of at least 4 invalid pixels along rows (shadows) exist; random dropouts alone rarely make them.
  std::size_t runs = 0;
  const int w = xtion.intrinsics.width;
  for (int v = 0; v < xtion.intrinsics.height; ++v) {
    int run = 0;
    for (int u = 0; u < w; ++u) {
      run = sim.frame.depth[static_cast<std::size_t>(v * w + u)] == 0 ? run + 1 : 0;
      if (run == 4) ++runs;
    }
  }
  CHECK(runs > 20);
  RenderOptions clean = test::noise_free();
  const SimulatedFrame without = render(scene, xtion, 3, clean);
  std::size_t invalid = 0;
  for (std::uint16_t d : without.frame.depth) invalid += d == 0 ? 1 : 0;
  CHECK(invalid == 0);
}
