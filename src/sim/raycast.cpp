// palletd sim: analytic ray casting of cuboids with a bulging top face and rounded top edges.
#include "raycast.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace palletd::sim::detail {
namespace {

/// Height of the top surface above the rim at local (x, y) [m] and its gradient.
double top_offset(const PreparedBox& b, double x, double y, Eigen::Vector2d* gradient) {
  const SimBox& box = *b.box;
  const double ux = x / b.hx, uy = y / b.hy;
  const double fx = std::max(0.0, 1.0 - ux * ux), fy = std::max(0.0, 1.0 - uy * uy);
  double h = box.bulge_m * fx * fy;
  Eigen::Vector2d g(box.bulge_m * (-2.0 * x / (b.hx * b.hx)) * fy, box.bulge_m * fx * (-2.0 * y / (b.hy * b.hy)));
  const double r = box.bevel_m;
  if (r > 0.0) {
    const double sx = b.hx - std::abs(x), sy = b.hy - std::abs(y);
    const bool x_edge = sx < sy;
    const double s = std::max(0.0, x_edge ? sx : sy);
    if (s < r) {
      const double q = r - s;
      const double root = std::sqrt(std::max(r * r - q * q, 1e-12));
      h -= r - root;
      // d(offset)/ds = q / root; s decreases toward the nearest edge.
      const double slope = std::min(q / root, 50.0);
      if (x_edge) {
        g.x() -= slope * (x >= 0.0 ? 1.0 : -1.0);
      } else {
        g.y() -= slope * (y >= 0.0 ? 1.0 : -1.0);
      }
    }
  }
  if (gradient) *gradient = g;
  return h;
}

double patch_reflectance(const SimBox& box, double x, double y) {
  double rho = box.reflectance;
  for (const SurfacePatch& p : box.patches)  // later patches lie on top
    if (std::abs(x - p.center.x()) <= p.half_size.x() && std::abs(y - p.center.y()) <= p.half_size.y()) rho = p.reflectance;
  return rho;
}

/// Slab test against [lo, hi] in local coordinates; entry axis 0/1/2 or -1 when starting inside.
bool slab(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
          double& t0, double& t1, int& axis) {
  t0 = -std::numeric_limits<double>::infinity();
  t1 = std::numeric_limits<double>::infinity();
  axis = -1;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      if (o[k] < lo[k] || o[k] > hi[k]) return false;
      continue;
    }
    const double inv = 1.0 / d[k];
    double ta = (lo[k] - o[k]) * inv, tb = (hi[k] - o[k]) * inv;
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) {
      t0 = ta;
      axis = k;
    }
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

/// Rounded vertical corners: a hit at local point p that lies in a corner square outside its
/// quarter circle is moved to where the ray enters that corner's vertical cylinder (radius r)
/// below the rim; false when the ray misses it (it passes the rounded corner by).
bool round_corner(const PreparedBox& b, const Eigen::Vector3d& lo_o, const Eigen::Vector3d& lo_d, double& t,
                  Eigen::Vector3d& local_normal, bool& top) {
  const double r = std::min(b.box->corner_radius_m, std::min(b.hx, b.hy));
  const Eigen::Vector3d p = lo_o + t * lo_d;
  const double cx = std::copysign(b.hx - r, p.x()), cy = std::copysign(b.hy - r, p.y());
  const double ex = p.x() - cx, ey = p.y() - cy;
  if (r <= 0.0 || std::abs(p.x()) <= b.hx - r || std::abs(p.y()) <= b.hy - r || ex * ex + ey * ey <= r * r)
    return true;  // not in a cut-away corner
  // Entering root of |(o + s d) - c|^2 = r^2 in the plane.
  const double ox = lo_o.x() - cx, oy = lo_o.y() - cy;
  const double qa = lo_d.x() * lo_d.x() + lo_d.y() * lo_d.y();
  const double qb = ox * lo_d.x() + oy * lo_d.y();
  const double qc = ox * ox + oy * oy - r * r;
  const double disc = qb * qb - qa * qc;
  if (qa < 1e-15 || disc < 0.0) return false;
  const double s = (-qb - std::sqrt(disc)) / qa;
  if (s < t) return false;
  const Eigen::Vector3d q = lo_o + s * lo_d;
  if (q.z() < b.z0 || q.z() > b.z1) return false;
  t = s;
  local_normal = Eigen::Vector3d(q.x() - cx, q.y() - cy, 0.0).normalized();
  top = false;
  return true;
}

}  // namespace

PreparedBox prepare(const SimBox& box) {
  PreparedBox b;
  b.box = &box;
  b.center = box.center;
  b.c = std::cos(box.yaw_rad);
  b.s = std::sin(box.yaw_rad);
  b.hx = 0.5 * box.long_m;
  b.hy = 0.5 * box.short_m;
  b.z0 = box.bottom_z_m;
  b.z1 = box.top_z_m;
  b.flat = box.bulge_m == 0.0 && box.bevel_m <= 0.0;
  b.zmax = box.top_z_m + std::max(box.bulge_m, 0.0);
  b.zmin_top = box.top_z_m + std::min(box.bulge_m, 0.0) - std::max(box.bevel_m, 0.0);
  const double ex = std::abs(b.c) * b.hx + std::abs(b.s) * b.hy;
  const double ey = std::abs(b.s) * b.hx + std::abs(b.c) * b.hy;
  b.aabb_lo = Eigen::Vector3d(box.center.x() - ex, box.center.y() - ey, b.z0);
  b.aabb_hi = Eigen::Vector3d(box.center.x() + ex, box.center.y() + ey, b.zmax);
  return b;
}

bool intersect(const PreparedBox& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_best,
               Hit& hit) {
  // World -> local: translate to the centre, rotate by -yaw.
  const double ox = o.x() - b.center.x(), oy = o.y() - b.center.y();
  const Eigen::Vector3d lo_o(b.c * ox + b.s * oy, -b.s * ox + b.c * oy, o.z());
  const Eigen::Vector3d lo_d(b.c * d.x() + b.s * d.y(), -b.s * d.x() + b.c * d.y(), d.z());
  double t0 = 0.0, t1 = 0.0;
  int axis = -1;
  if (!slab(lo_o, lo_d, Eigen::Vector3d(-b.hx, -b.hy, b.z0), Eigen::Vector3d(b.hx, b.hy, b.zmax), t0, t1, axis))
    return false;
  if (axis < 0 || t0 <= t_min || t0 >= t_best) return false;

  auto local_normal_to_world = [&](const Eigen::Vector3d& n) {
    return Eigen::Vector3d(b.c * n.x() - b.s * n.y(), b.s * n.x() + b.c * n.y(), n.z());
  };
  auto side_normal = [&](int k) {
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n[k] = lo_d[k] > 0.0 ? -1.0 : 1.0;
    return n;
  };
  auto surface = [&](double t) {  // height above the surface (> 0: above)
    const Eigen::Vector3d p = lo_o + t * lo_d;
    return p.z() - (b.z1 + top_offset(b, p.x(), p.y(), nullptr));
  };

  double t = t0;
  bool top = axis == 2;
  if (!b.flat) {
    const double f0 = surface(t0);
    if (f0 <= 0.0) {
      top = axis == 2;  // otherwise it enters through a side face below the rim
    } else {
      if (lo_d.z() >= 0.0) return false;
      double tb = std::min(t1, (b.zmin_top - lo_o.z()) / lo_d.z());
      double fb = surface(tb);
      if (fb > 0.0) return false;  // passes above a rounded edge
      double ta = t0, fa = f0;
      int side = 0;
      for (int it = 0; it < 30; ++it) {  // Illinois regula falsi
        t = (ta * fb - tb * fa) / (fb - fa);
        const double ft = surface(t);
        if (std::abs(ft) < 1e-7) break;
        if ((ft > 0.0) == (fa > 0.0)) {
          ta = t;
          fa = ft;
          if (side == -1) fb *= 0.5;
          side = -1;
        } else {
          tb = t;
          fb = ft;
          if (side == 1) fa *= 0.5;
          side = 1;
        }
      }
      top = true;
      if (t >= t_best) return false;
    }
  }
  Eigen::Vector3d corner_normal = Eigen::Vector3d::Zero();
  if (b.box->corner_radius_m > 0.0) {
    if (!round_corner(b, lo_o, lo_d, t, corner_normal, top) || t >= t_best) return false;
  }
  hit.t = t;
  const Eigen::Vector3d p = lo_o + t * lo_d;
  if (corner_normal.squaredNorm() > 0.0) {
    hit.normal = local_normal_to_world(corner_normal);
    hit.reflectance = b.box->reflectance;
  } else if (top) {
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    if (!b.flat) top_offset(b, p.x(), p.y(), &g);
    hit.normal = local_normal_to_world(Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized());
    hit.reflectance = patch_reflectance(*b.box, p.x(), p.y());
  } else {
    hit.normal = local_normal_to_world(side_normal(axis));
    hit.reflectance = b.box->reflectance;
  }
  return true;
}

bool blocks_segment(const PreparedBox& b, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min) {
  // Cheap world AABB rejection first.
  double t0 = 0.0, t1 = 0.0;
  int axis = -1;
  if (!slab(o, d, b.aabb_lo, b.aabb_hi, t0, t1, axis)) return false;
  if (t1 <= t_min || t0 >= 1.0) return false;
  const double ox = o.x() - b.center.x(), oy = o.y() - b.center.y();
  const Eigen::Vector3d lo_o(b.c * ox + b.s * oy, -b.s * ox + b.c * oy, o.z());
  const Eigen::Vector3d lo_d(b.c * d.x() + b.s * d.y(), -b.s * d.x() + b.c * d.y(), d.z());
  if (!slab(lo_o, lo_d, Eigen::Vector3d(-b.hx, -b.hy, b.z0), Eigen::Vector3d(b.hx, b.hy, b.z1), t0, t1, axis))
    return false;
  return axis >= 0 && t0 > t_min && t0 < 1.0;
}

}  // namespace palletd::sim::detail
