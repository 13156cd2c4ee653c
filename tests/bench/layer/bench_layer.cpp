// palletd_bench_layer [--count N] [--seed S] [--profiles a,b,...] [--no-sweep] [--stages] [--why] [--dump DIR]
// --why: where the outline error lies (false/missed area widths, signed outline offsets by
// whether an edge faces the camera); --stages: CPU time per stage; --dump: debug pictures.
// Accuracy and speed of extract_layer() on simulator frames (every profile, tilt up to 30 deg,
// every pattern, fill 0.3-1), and a hole / cluster sweep on analytic scenes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "palletd/detection/layer.hpp"
#include "palletd/detection/layer_debug.hpp"
#include "layer_stages.hpp"
#include "palletd/sim/sim.hpp"
#include "synthetic_scene.hpp"

using namespace palletd;

namespace {

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)));
  return v[i];
}

/// Where the outline error lies, as widths along the truth outline [mm]: false area inside the
/// gaps between truth boxes (closed by 20 mm), false area elsewhere outside, missed area.
struct Breakdown {
  double fp_gap_mm = 0.0, fp_out_mm = 0.0, fn_mm = 0.0;
};

Breakdown breakdown(const std::vector<PolygonWithHoles>& polygons, const std::vector<std::vector<Eigen::Vector2d>>& truth) {
  const double cell = 0.001;
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  double perimeter = 0.0;
  for (const auto& t : truth)
    for (std::size_t k = 0; k < t.size(); ++k) {
      lo = lo.cwiseMin(t[k]);
      hi = hi.cwiseMax(t[k]);
      perimeter += (t[(k + 1) % t.size()] - t[k]).norm();
    }
  for (const auto& p : polygons)
    for (const auto& q : p.outer) {
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  lo -= Eigen::Vector2d(0.05, 0.05);
  hi += Eigen::Vector2d(0.05, 0.05);
  const int w = static_cast<int>((hi.x() - lo.x()) / cell), h = static_cast<int>((hi.y() - lo.y()) / cell);
  Breakdown b;
  if (w <= 0 || h <= 0 || static_cast<long>(w) * h > 40'000'000L || perimeter <= 0.0) return b;
  auto px = [&](const std::vector<Eigen::Vector2d>& ring) {
    std::vector<cv::Point> out;
    for (const auto& q : ring)
      out.emplace_back(static_cast<int>(std::lround((q.x() - lo.x()) / cell * 256)), static_cast<int>(std::lround((q.y() - lo.y()) / cell * 256)));
    return out;
  };
  cv::Mat det(h, w, CV_8U, cv::Scalar(0)), tru(h, w, CV_8U, cv::Scalar(0));
  for (const auto& p : polygons) {
    cv::Mat one(h, w, CV_8U, cv::Scalar(0));
    cv::fillPoly(one, std::vector<std::vector<cv::Point>>{px(p.outer)}, cv::Scalar(255), cv::LINE_8, 8);
    for (const auto& hole : p.holes) cv::fillPoly(one, std::vector<std::vector<cv::Point>>{px(hole)}, cv::Scalar(0), cv::LINE_8, 8);
    cv::bitwise_or(det, one, det);
  }
  for (const auto& t : truth) cv::fillPoly(tru, std::vector<std::vector<cv::Point>>{px(t)}, cv::Scalar(255), cv::LINE_8, 8);
  cv::Mat closed, fp, fn, gap;
  cv::morphologyEx(tru, closed, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(21, 21)));
  cv::bitwise_and(det, ~tru, fp);
  cv::bitwise_and(tru, ~det, fn);
  cv::bitwise_and(fp, closed, gap);
  const double to_mm = cell * cell / perimeter * 1000.0;
  b.fp_gap_mm = cv::countNonZero(gap) * to_mm;
  b.fp_out_mm = (cv::countNonZero(fp) - cv::countNonZero(gap)) * to_mm;
  b.fn_mm = cv::countNonZero(fn) * to_mm;
  return b;
}

bool inside_ring(const std::vector<Eigen::Vector2d>& r, const Eigen::Vector2d& q) {
  bool in = false;
  for (std::size_t i = 0, j = r.size() - 1; i < r.size(); j = i++)
    if ((r[i].y() > q.y()) != (r[j].y() > q.y()) &&
        q.x() < (r[j].x() - r[i].x()) * (q.y() - r[i].y()) / (r[j].y() - r[i].y()) + r[i].x())
      in = !in;
  return in;
}

double seg_dist(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& q) {
  const Eigen::Vector2d d = b - a;
  const double t = std::clamp((q - a).dot(d) / std::max(d.squaredNorm(), 1e-12), 0.0, 1.0);
  return (a + t * d - q).norm();
}

/// Signed offsets [mm] of the detected outline from the truth outline edges (+ = detection
/// outside), binned by whether the edge faces the camera (0), faces away (1), or is seen sideways (2).
void edge_offsets(const std::vector<PolygonWithHoles>& polygons, const std::vector<std::vector<Eigen::Vector2d>>& truth,
                  const Eigen::Vector2d& camera_xy, std::vector<double> (&bins)[3]) {
  for (const auto& t : truth) {
    const double a = signed_area(t);
    for (std::size_t k = 0; k < t.size(); ++k) {
      const Eigen::Vector2d p0 = t[k], p1 = t[(k + 1) % t.size()];
      const Eigen::Vector2d dir = (p1 - p0).normalized();
      Eigen::Vector2d n(dir.y(), -dir.x());
      if (a < 0.0) n = -n;  // outward
      for (double f = 0.2; f <= 0.81; f += 0.1) {
        const Eigen::Vector2d q = p0 + f * (p1 - p0);
        bool covered = false;
        for (const auto& o : truth) covered = covered || inside_ring(o, q + 0.02 * n);
        if (covered) continue;  // an inner seam
        bool in = false;
        double best = 1e9;
        for (const auto& poly : polygons) {
          bool here = inside_ring(poly.outer, q);
          for (const auto& h : poly.holes) here = here && !inside_ring(h, q);
          in = in || here;
          auto scan = [&](const std::vector<Eigen::Vector2d>& r) {
            for (std::size_t i = 0; i < r.size(); ++i) best = std::min(best, seg_dist(r[i], r[(i + 1) % r.size()], q));
          };
          scan(poly.outer);
          for (const auto& h : poly.holes) scan(h);
        }
        if (best > 0.05) continue;
        const Eigen::Vector2d to_cam = camera_xy - q;
        const double c = to_cam.norm() > 1e-6 ? n.dot(to_cam.normalized()) : 0.0;
        const int bin = c > 0.5 ? 0 : (c < -0.5 ? 1 : 2);
        bins[bin].push_back(1000.0 * (in ? best : -best));
      }
    }
  }
}

struct Stats {
  std::vector<double> edge[3];
  int frames = 0, ok = 0;
  std::vector<double> fp_gap, fp_out, fn;
  std::vector<double> iou_observed, iou_unobserved;  // layer fully observed / outline along invalid pixels
  std::vector<double> iou, height_mm, normal_deg, time_ms, plane_ms, layer_ms, contour_ms;
};

double min_of(const std::vector<double>& v) { return v.empty() ? std::nan("") : *std::min_element(v.begin(), v.end()); }

/// IoU over frames whose layer is fully observed, and over those whose outline runs along
/// invalid pixels (LayerDiagnostics::outline_along_invalid): the honest split.
void print_observed(const Stats& s) {
  std::printf("    fully observed: %zu frames, IoU median %.4f, min %.4f; outline along invalid pixels: %zu frames, "
              "IoU median %.4f, min %.4f\n",
              s.iou_observed.size(), quantile(s.iou_observed, 0.5), min_of(s.iou_observed), s.iou_unobserved.size(),
              quantile(s.iou_unobserved, 0.5), min_of(s.iou_unobserved));
}

void print_row(const std::string& name, const Stats& s) {
  std::printf("| %-13s | %4d | %4d | %6.4f | %6.4f | %5.2f | %5.2f | %5.3f | %5.3f | %5.2f | %5.2f | %4.1f/%4.1f/%4.1f |\n",
              name.c_str(), s.frames, s.ok, quantile(s.iou, 0.5), s.iou.empty() ? std::nan("") : *std::min_element(s.iou.begin(), s.iou.end()),
              quantile(s.height_mm, 0.5), quantile(s.height_mm, 1.0), quantile(s.normal_deg, 0.5),
              quantile(s.normal_deg, 1.0), quantile(s.time_ms, 0.5), quantile(s.time_ms, 0.9),
              quantile(s.plane_ms, 0.5), quantile(s.layer_ms, 0.5), quantile(s.contour_ms, 0.5));
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(item);
  return out;
}

void sweep() {
  using namespace palletd::testing;
  std::printf("\nHole and cluster sweep (analytic scenes, 640x480, f=570 px, 1.8 m to the layer, 3 seeds;\n"
              "pitch = 1.8 m / 570 px = 3.16 mm; hole = gap around the centre box of a 3x3 layer)\n");
  std::printf("| gap [mm] | gap [pitch] | holes found, tilt 0 / 20 deg (of 3) | separate clusters, tilt 0 / 20 deg (of 3) |\n|---|---|---|---|\n");
  const double pitch_m = 1.8 / 570.0;
  for (const double gap_mm : {2.0, 3.0, 4.0, 4.75, 6.0, 8.0, 10.0, 20.0, 30.0, 40.0}) {
    int holes[2] = {0, 0}, clusters[2] = {0, 0};
    for (int t = 0; t < 2; ++t)
    for (std::uint32_t seed = 1; seed <= 3; ++seed) {
      SynthCamera cam;
      cam.tilt_deg = t == 0 ? 0.0 : 20.0;
      cam.tilt_azimuth_deg = 40.0 * seed;
      cam.look_at = Eigen::Vector3d(0, 0, 1.0);
      SynthNoise noise;
      noise.seed = seed;
      // Hole: a ring of boxes around a gap (3x3 with the centre box shrunk by the gap).
      SynthScene ring = grid_layer(3, 3, 0.0, 1.0, true);
      SynthBox& mid = ring.boxes[5];
      mid.long_m -= 2 * gap_mm / 1000.0;
      mid.short_m -= 2 * gap_mm / 1000.0;
      const SynthFrame fr = render_synthetic(ring, cam, noise);
      const LayerResult rr = extract_layer(fr.frame, fr.cloud, {}, {}, {}, 0.036);
      if (rr.status == DetectionStatus::kOk && rr.polygons.size() >= 1) {
        std::size_t n = 0;
        for (const auto& p : rr.polygons) n += p.holes.size();
        if (n >= 1) ++holes[t];
      }
      // Clusters: two boxes gap_mm apart.
      SynthScene two = grid_layer(2, 1, gap_mm / 1000.0, 1.0, true);
      const SynthFrame ft = render_synthetic(two, cam, noise);
      const LayerResult rt = extract_layer(ft.frame, ft.cloud, {}, {}, {}, 0.036);
      if (rt.status == DetectionStatus::kOk && rt.polygons.size() == 2) ++clusters[t];
    }
    std::printf("| %5.2f | %4.2f | %d / %d | %d / %d |\n", gap_mm, gap_mm / 1000.0 / pitch_m, holes[0], holes[1], clusters[0],
                clusters[1]);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int count = 120;
  std::uint64_t seed = 1;
  std::vector<std::string> profiles;
  bool do_sweep = true;
  bool stage_times = false;
  bool why = false;  // where the outline error lies (per profile)
  std::vector<double> stage_ms[3];
  std::string dump_dir;  // debug pictures of frames below IoU 0.95 (bench only; detection writes nothing)
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--count" && i + 1 < argc) count = std::atoi(argv[++i]);
    else if (a == "--seed" && i + 1 < argc) seed = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--profiles" && i + 1 < argc) profiles = split(argv[++i]);
    else if (a == "--no-sweep") do_sweep = false;
    else if (a == "--stages") stage_times = true;
    else if (a == "--why") why = true;
    else if (a == "--dump" && i + 1 < argc) dump_dir = argv[++i];
    else {
      std::fprintf(stderr, "usage: palletd_bench_layer [--count N] [--seed S] [--profiles a,b] [--no-sweep] [--stages] [--why] [--dump DIR]\n");
      return 2;
    }
  }
  cv::setNumThreads(1);  // one core
  if (profiles.empty()) profiles = sim::profile_names();

  std::printf("extract_layer on %d simulator frames per profile (seed %llu, tilt <= 30 deg, all patterns, fill 0.3-1)\n",
              count, static_cast<unsigned long long>(seed));
  std::printf("| profile       | n    | ok   | IoU med | IoU min | h med mm | h max mm | n med deg | n max deg | cpu med ms | cpu p90 ms | plane/layer/contour med wall ms |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  Stats all;
  std::vector<std::string> worst;
  for (const std::string& profile : profiles) {
    sim::SetOptions so;
    so.count = count;
    so.seed = seed;
    so.profiles = {profile};
    so.fill_min = 0.3;
    so.fill_max = 1.0;
    so.scenario.tilt_max_deg = 30.0;
    auto set = sim::generate_set(so);
    if (!set) {
      std::fprintf(stderr, "%s: %s\n", profile.c_str(), set.error().c_str());
      continue;
    }
    Stats st;
    RayTable rays;
    OrganizedCloud cloud;
    for (const sim::SimulatedFrame& f : set.value()) {
      if (!rays.matches(f.frame.intrinsics)) rays = RayTable(f.frame.intrinsics);
      to_organized_cloud(f.frame, rays, cloud);
      double min_box = 1e9;
      for (const auto& mm : f.truth.recipe_mm) min_box = std::min(min_box, mm[0] * mm[1] * 1e-6);
      if (min_box > 1e8) min_box = 0.07;
      // CPU time of this thread: the machine is shared, wall time would measure the others too.
      const double c0 = thread_cpu_ms();
      const LayerResult r = extract_layer(f.frame, cloud, {}, {}, {}, 0.5 * min_box);
      const double ms = thread_cpu_ms() - c0;
      auto dump = [&]() {
        if (dump_dir.empty()) return;
        LayerTrace trace;
        const LayerResult again = extract_layer(f.frame, cloud, {}, {}, {}, 0.5 * min_box, &trace);
        for (const auto& [stage, img] : render_layer_debug_images(f.frame, again, trace))
          cv::imwrite(dump_dir + "/" + f.name + "." + stage + ".png", img);
        // Per truth box: share of its pixels on the layer mask, mean residual to the plane [mm].
        std::printf("  %s: tol %.1f mm sigma %.1f mm\n", f.name.c_str(), 1000 * again.diagnostics.passthrough_tolerance_m,
                    1000 * again.diagnostics.plane_sigma_m);
        for (const TruthBox& b : f.truth.boxes) {
          std::vector<cv::Point> poly;
          for (const Eigen::Vector3d& c : sim::truth_corners(b)) {
            Eigen::Vector2d px;
            if (sim::project(f.frame.intrinsics, c, px)) poly.emplace_back(static_cast<int>(px.x()), static_cast<int>(px.y()));
          }
          cv::Mat m(f.frame.intrinsics.height, f.frame.intrinsics.width, CV_8U, cv::Scalar(0));
          cv::fillPoly(m, std::vector<std::vector<cv::Point>>{poly}, cv::Scalar(255));
          int n = 0, on = 0;
          double res = 0.0;
          int nres = 0;
          for (int v = 0; v < m.rows; ++v)
            for (int u = 0; u < m.cols; ++u) {
              if (m.at<std::uint8_t>(v, u) == 0) continue;
              ++n;
              const std::size_t i = static_cast<std::size_t>(v * m.cols + u);
              if (trace.layer_mask[i] != 0) ++on;
              const Eigen::Vector3f& p = cloud.points[i];
              if (p.allFinite()) {
                res += again.plane_camera.signed_distance(p.cast<double>());
                ++nres;
              }
            }
          std::printf("    box %s: %d px, %.2f on layer, mean residual %.1f mm\n", b.format.c_str(), n,
                      n > 0 ? static_cast<double>(on) / n : 0.0, nres > 0 ? 1000 * res / nres : 0.0);
        }
      };
      if (stage_times) {
        // CPU time of the stages alone (private stage functions, same order as extract_layer).
        double c = thread_cpu_ms();
        const layer::TopPlane top = layer::find_top_plane(cloud, f.frame.intrinsics, PlaneParams{});
        double c1 = thread_cpu_ms();
        stage_ms[0].push_back(c1 - c);
        if (top.status == DetectionStatus::kOk) {
          c = c1;
          layer::LayerMask lm = layer::layer_mask(cloud, top.plane, layer::BandTable(top.noise, 0.0), PlaneParams{});
          c1 = thread_cpu_ms();
          stage_ms[1].push_back(c1 - c);
          c = c1;
          layer::Components comps = layer::find_components(lm.mask, lm.border, cloud, top.plane, f.frame.intrinsics, 0.5 * min_box, 4);
          c1 = thread_cpu_ms();
          stage_ms[2].push_back(c1 - c);
        }
      }
      ++st.frames;
      st.time_ms.push_back(ms);
      if (r.status != DetectionStatus::kOk) {
        worst.push_back(f.name + ": " + to_string(r.status) + " " + r.reason);
        dump();
        st.iou.push_back(0.0);
        continue;
      }
      ++st.ok;
      st.plane_ms.push_back(r.diagnostics.t_plane_ms);
      st.layer_ms.push_back(r.diagnostics.t_layer_ms);
      st.contour_ms.push_back(r.diagnostics.t_contour_ms);
      const Eigen::Isometry3d T_layer_camera = r.T_camera_layer.inverse();
      std::vector<std::vector<Eigen::Vector2d>> truth;
      for (const TruthBox& b : f.truth.boxes) {
        std::vector<Eigen::Vector2d> quad;
        for (const Eigen::Vector3d& c : sim::truth_corners(b)) quad.push_back((T_layer_camera * c).head<2>());
        truth.push_back(quad);
      }
      const double iou = testing::polygon_iou(r.polygons, truth, 0.001);
      st.iou.push_back(iou);
      (r.diagnostics.outline_along_invalid ? st.iou_unobserved : st.iou_observed).push_back(iou);
      if (why) {
        const Breakdown bd = breakdown(r.polygons, truth);
        st.fp_gap.push_back(bd.fp_gap_mm);
        st.fp_out.push_back(bd.fp_out_mm);
        st.fn.push_back(bd.fn_mm);
        edge_offsets(r.polygons, truth, (T_layer_camera * Eigen::Vector3d::Zero()).head<2>(), st.edge);
      }
      if (iou < 0.95) {
        double a_det = 0.0, a_truth = 0.0;
        for (const auto& p : r.polygons) a_det += area(p);
        for (const auto& q : truth) a_truth += std::abs(signed_area(q));
        worst.push_back(f.name + ": IoU " + std::to_string(iou) + " area ratio " + std::to_string(a_det / a_truth) +
                        " components " + std::to_string(r.polygons.size()) + " unobserved outline " +
                        std::to_string(r.diagnostics.unobserved_outline_fraction) + " " + f.scene.description);
        dump();
      }
      st.height_mm.push_back(1000.0 * std::abs(f.truth.layer_plane.signed_distance(r.T_camera_layer.translation())));
      st.normal_deg.push_back(
          std::acos(std::clamp(std::abs(r.plane_camera.normal.dot(f.truth.layer_plane.normal)), 0.0, 1.0)) *
          180.0 / M_PI);
    }
    print_row(profile, st);
    print_observed(st);
    if (why)
      std::printf("    error widths along the truth outline, median [mm]: false in gaps %.2f, false outside %.2f, missed %.2f\n",
                  quantile(st.fp_gap, 0.5), quantile(st.fp_out, 0.5), quantile(st.fn, 0.5));
    if (why)
      for (int b = 0; b < 3; ++b)
        std::printf("    outline offset, edges %s: median %+.2f mm, p10 %+.2f, p90 %+.2f (%zu samples)\n",
                    b == 0 ? "facing the camera" : (b == 1 ? "facing away      " : "seen sideways    "),
                    quantile(st.edge[b], 0.5), quantile(st.edge[b], 0.1), quantile(st.edge[b], 0.9), st.edge[b].size());
    auto append = [](std::vector<double>& a, const std::vector<double>& b) { a.insert(a.end(), b.begin(), b.end()); };
    all.frames += st.frames;
    all.ok += st.ok;
    append(all.iou, st.iou);
    append(all.iou_observed, st.iou_observed);
    append(all.iou_unobserved, st.iou_unobserved);
    append(all.height_mm, st.height_mm);
    append(all.normal_deg, st.normal_deg);
    append(all.time_ms, st.time_ms);
    append(all.plane_ms, st.plane_ms);
    append(all.layer_ms, st.layer_ms);
    append(all.contour_ms, st.contour_ms);
  }
  print_row("all", all);
  print_observed(all);
  if (stage_times)
    std::printf("\nStage CPU medians [ms]: plane %.2f, mask %.2f, components %.2f (rest of extract_layer = crust, polygons, points_2d)\n",
                quantile(stage_ms[0], 0.5), quantile(stage_ms[1], 0.5), quantile(stage_ms[2], 0.5));
  if (!worst.empty()) {
    std::printf("\nFrames below IoU 0.95 or failed (%zu):\n", worst.size());
    for (std::size_t i = 0; i < worst.size() && i < 30; ++i) std::printf("  %s\n", worst[i].c_str());
  }
  if (do_sweep) sweep();
  return 0;
}
