// Stage 5a: the crust (paper Section III): CGAL Delaunay triangulation of the border points,
// edges longer than d_max pruned, convex-hull anchors joined by shortest paths into a ring.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <opencv2/calib3d.hpp>

#include "layer_stages.hpp"

namespace palletd::layer {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<int, Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, Tds>;

}  // namespace

PixelToLayer::PixelToLayer(const Intrinsics& intrinsics, const Plane& plane,
                           const Eigen::Isometry3d& T_camera_layer)
    : intrinsics_(intrinsics), plane_(plane), T_layer_camera_(T_camera_layer.inverse()) {
  if (intrinsics.distortion) {
    camera_matrix_ = (cv::Mat_<double>(3, 3) << intrinsics.fx, 0.0, intrinsics.cx, 0.0, intrinsics.fy,
                      intrinsics.cy, 0.0, 0.0, 1.0);
    distortion_ = cv::Mat(1, 5, CV_64F);
    for (int i = 0; i < 5; ++i) distortion_.at<double>(i) = (*intrinsics.distortion)[static_cast<std::size_t>(i)];
  }
}

Eigen::Vector2d PixelToLayer::operator()(double u, double v) const {
  Eigen::Vector3d ray((u - intrinsics_.cx) / intrinsics_.fx, (v - intrinsics_.cy) / intrinsics_.fy, 1.0);
  if (!distortion_.empty()) {
    std::vector<cv::Point2d> in{cv::Point2d(u, v)}, out;
    cv::undistortPoints(in, out, camera_matrix_, distortion_);
    ray = Eigen::Vector3d(out[0].x, out[0].y, 1.0);
  }
  const double denom = plane_.normal.dot(ray);
  // Rays (nearly) parallel to the plane: clamp far away instead of dividing by zero.
  const double t = std::abs(denom) > 1e-9 ? -plane_.d / denom : 1e3;
  const Eigen::Vector3d q = T_layer_camera_ * (ray * t);
  return q.head<2>();
}

std::vector<int> crust_ring(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& chain,
                            double d_max_m, std::vector<std::pair<int, int>>* kept_edges) {
  const int n = static_cast<int>(points.size());
  std::vector<int> by_chain(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) by_chain[static_cast<std::size_t>(i)] = i;
  std::stable_sort(by_chain.begin(), by_chain.end(), [&](int a, int b) {
    return chain[static_cast<std::size_t>(a)] < chain[static_cast<std::size_t>(b)];
  });
  if (n < 4) return by_chain;

  std::vector<std::pair<Delaunay::Point, int>> input;
  input.reserve(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    input.emplace_back(Delaunay::Point(points[static_cast<std::size_t>(i)].x(), points[static_cast<std::size_t>(i)].y()), i);
  Delaunay dt;
  dt.insert(input.begin(), input.end());
  if (dt.dimension() < 2) return by_chain;

  // Pruned graph.
  std::vector<std::vector<std::pair<int, double>>> adj(static_cast<std::size_t>(n));
  for (auto e = dt.finite_edges_begin(); e != dt.finite_edges_end(); ++e) {
    const auto va = e->first->vertex(Delaunay::cw(e->second));
    const auto vb = e->first->vertex(Delaunay::ccw(e->second));
    const int a = va->info(), b = vb->info();
    const double len = (points[static_cast<std::size_t>(a)] - points[static_cast<std::size_t>(b)]).norm();
    if (len > d_max_m) continue;
    adj[static_cast<std::size_t>(a)].emplace_back(b, len);
    adj[static_cast<std::size_t>(b)].emplace_back(a, len);
    if (kept_edges) kept_edges->emplace_back(a, b);
  }
  // Duplicate points (same pixel ray twice) are merged by CGAL: their twins join the graph here.
  for (int i = 0; i < n; ++i) {
    if (!adj[static_cast<std::size_t>(i)].empty()) continue;
    const auto vh = dt.nearest_vertex(input[static_cast<std::size_t>(i)].first);
    if (vh != nullptr && vh->info() != i) {
      adj[static_cast<std::size_t>(i)].emplace_back(vh->info(), 0.0);
      adj[static_cast<std::size_t>(vh->info())].emplace_back(i, 0.0);
    }
  }

  // Convex-hull anchors in chain order.
  std::vector<int> anchors;
  auto circ = dt.incident_vertices(dt.infinite_vertex());
  const auto start = circ;
  do {
    if (!dt.is_infinite(circ)) anchors.push_back(circ->info());
    ++circ;
  } while (circ != start);
  std::sort(anchors.begin(), anchors.end(), [&](int a, int b) {
    return chain[static_cast<std::size_t>(a)] < chain[static_cast<std::size_t>(b)];
  });
  anchors.erase(std::unique(anchors.begin(), anchors.end(), [&](int a, int b) {
                  return chain[static_cast<std::size_t>(a)] == chain[static_cast<std::size_t>(b)];
                }), anchors.end());
  if (anchors.size() < 2) return by_chain;

  const int chain_len = *std::max_element(chain.begin(), chain.end()) + 1;
  const int slack = 4;
  std::vector<double> dist(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
  std::vector<int> prev(static_cast<std::size_t>(n), -1);
  std::vector<int> touched;
  std::vector<int> ring;
  ring.reserve(static_cast<std::size_t>(n));
  using Item = std::pair<double, int>;
  for (std::size_t k = 0; k < anchors.size(); ++k) {
    const int a = anchors[k], b = anchors[(k + 1) % anchors.size()];
    const int ca = chain[static_cast<std::size_t>(a)];
    const int span = ((chain[static_cast<std::size_t>(b)] - ca) % chain_len + chain_len) % chain_len;
    auto allowed = [&](int i) {
      const int off = ((chain[static_cast<std::size_t>(i)] - ca) % chain_len + chain_len) % chain_len;
      return off <= span + slack || off >= chain_len - slack;
    };
    for (const int t : touched) {
      dist[static_cast<std::size_t>(t)] = std::numeric_limits<double>::infinity();
      prev[static_cast<std::size_t>(t)] = -1;
    }
    touched.clear();
    std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
    dist[static_cast<std::size_t>(a)] = 0.0;
    touched.push_back(a);
    queue.emplace(0.0, a);
    while (!queue.empty()) {
      const auto [du, u] = queue.top();
      queue.pop();
      if (u == b) break;
      if (du > dist[static_cast<std::size_t>(u)]) continue;
      for (const auto& [w, len] : adj[static_cast<std::size_t>(u)]) {
        if (!allowed(w)) continue;
        const double nd = du + len;
        if (nd < dist[static_cast<std::size_t>(w)]) {
          if (std::isinf(dist[static_cast<std::size_t>(w)])) touched.push_back(w);
          dist[static_cast<std::size_t>(w)] = nd;
          prev[static_cast<std::size_t>(w)] = u;
          queue.emplace(nd, w);
        }
      }
    }
    if (std::isfinite(dist[static_cast<std::size_t>(b)])) {
      std::vector<int> path;
      for (int u = b; u != a && u >= 0; u = prev[static_cast<std::size_t>(u)]) path.push_back(u);
      path.push_back(a);
      std::reverse(path.begin(), path.end());
      ring.insert(ring.end(), path.begin(), path.end() - 1);  // b starts the next path
    } else {
      // Broken graph (gap longer than d_max): follow the traced chain for this stretch.
      for (const int i : by_chain) {
        const int off = ((chain[static_cast<std::size_t>(i)] - ca) % chain_len + chain_len) % chain_len;
        if (off < span || (span == 0 && i == a)) ring.push_back(i);
      }
    }
  }
  return ring;
}

}  // namespace palletd::layer
