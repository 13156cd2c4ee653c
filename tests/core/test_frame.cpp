#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/core/frame.hpp"

using palletd::Frame;
using palletd::Intrinsics;

namespace {
Frame make_frame(int w, int h, std::uint16_t value, double scale) {
  Frame f;
  f.intrinsics = Intrinsics{w, h, 100.0, 110.0, (w - 1) / 2.0, (h - 1) / 2.0, std::nullopt};
  f.depth.assign(static_cast<std::size_t>(w * h), value);
  f.depth_scale_m = scale;
  return f;
}
}  // namespace

TEST_CASE("organized cloud follows the pinhole model and honours depth_scale") {
  Frame f = make_frame(8, 6, 8000, 0.00025);  // 2.0 m at 0.25 mm units
  f.depth[0] = 0;
  palletd::RayTable rays(f.intrinsics);
  palletd::OrganizedCloud cloud;
  palletd::to_organized_cloud(f, rays, cloud);
  REQUIRE(cloud.points.size() == 48);
  CHECK(std::isnan(cloud.at(0, 0).z()));
  const Eigen::Vector3f p = cloud.at(7, 5);
  CHECK(p.z() == Approx(2.0f));
  CHECK(p.x() == Approx((7 - 3.5) * 2.0 / 100.0));
  CHECK(p.y() == Approx((5 - 2.5) * 2.0 / 110.0));
}

TEST_CASE("ray table undistorts: a distorted pixel maps back to its undistorted ray") {
  Intrinsics in{64, 48, 50.0, 50.0, 31.5, 23.5, std::array<double, 5>{-0.2, 0.05, 0.001, -0.001, 0.0}};
  palletd::RayTable rays(in);
  // Distort a known normalised point forward with the plumb-bob model, find its pixel, and
  // check the table returns (close to) the original point at that pixel.
  const double x = 0.3, y = -0.2;
  const auto& k = *in.distortion;
  const double r2 = x * x + y * y;
  const double radial = 1 + k[0] * r2 + k[1] * r2 * r2 + k[4] * r2 * r2 * r2;
  const double xd = x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x);
  const double yd = y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y;
  const double u = in.fx * xd + in.cx, v = in.fy * yd + in.cy;
  // Choose a point that lands on a pixel centre by construction tolerance: compare at nearest pixel.
  const auto ui = static_cast<int>(std::lround(u)), vi = static_cast<int>(std::lround(v));
  const auto& ray = rays.ray(static_cast<std::size_t>(vi * in.width + ui));
  CHECK(ray.x() == Approx(x).margin(0.02));
  CHECK(ray.y() == Approx(y).margin(0.02));
  CHECK(rays.matches(in));
  Intrinsics other = in;
  other.distortion.reset();
  CHECK_FALSE(rays.matches(other));
}
