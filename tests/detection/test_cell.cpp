// detect() in a cell: a cabinet taller than the load beside the pallet, the region of interest
// that leaves it out, and the calibrated up direction that keeps only level planes.
#include <cmath>
#include <utility>

#include <catch2/catch.hpp>

#include "palletd/detection/detection.hpp"

#include "synthetic_scene.hpp"

using namespace palletd;
using namespace palletd::testing;

namespace {

constexpr double kLoadTop_m = 1.0;     // the top layer's height above the floor
constexpr double kCabinetTop_m = 1.6;  // the cabinet beside the pallet, taller than the load

/// A 3 x 2 layer of 315 x 232 boxes on a lower layer, and a cabinet 0.6 m beside it.
SynthScene cell_scene() {
  SynthScene s = grid_layer(3, 2, 0.004, kLoadTop_m, true);
  SynthBox cabinet;
  cabinet.center = Eigen::Vector2d(1.05, 0.0);
  cabinet.long_m = 0.6;
  cabinet.short_m = 0.5;
  cabinet.bottom_z_m = 0.0;
  cabinet.top_z_m = kCabinetTop_m;
  s.boxes.push_back(cabinet);
  return s;
}

/// The camera 2.4 m above the load, tilted 8 deg, seeing the load and the cabinet; the frame
/// carries the calibration (the scene's world is the robot base: z up, floor at 0).
SynthFrame cell_frame() {
  SynthCamera cam = camera_looking_at(kLoadTop_m, 8.0, 30.0);
  cam.distance_m = 2.4;
  cam.look_at = Eigen::Vector3d(0.3, 0.0, kLoadTop_m);
  SynthNoise noise;
  noise.dropout = 0.0;
  SynthFrame f = render_synthetic(cell_scene(), cam, noise);
  f.frame.T_base_camera = f.T_world_camera;
  return f;
}

const std::vector<BoxFormat> kFormats = {{0.315, 0.232, "315x232"}};

RegionOfInterest load_region() {
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kBase;
  roi.min_m = Eigen::Vector3d(-0.65, -0.45, 0.05);
  roi.max_m = Eigen::Vector3d(0.65, 0.45, 1.4);
  return roi;
}

/// The camera-frame box around the base-frame box lo..hi (its corners seen from the camera).
RegionOfInterest camera_region(const Eigen::Isometry3d& T_camera_base, const Eigen::Vector3d& lo,
                               const Eigen::Vector3d& hi) {
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kCamera;
  roi.min_m = Eigen::Vector3d::Constant(1e9);
  roi.max_m = Eigen::Vector3d::Constant(-1e9);
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d q((corner & 1) != 0 ? hi.x() : lo.x(), (corner & 2) != 0 ? hi.y() : lo.y(),
                            (corner & 4) != 0 ? hi.z() : lo.z());
    const Eigen::Vector3d p = T_camera_base * q;
    roi.min_m = roi.min_m.cwiseMin(p);
    roi.max_m = roi.max_m.cwiseMax(p);
  }
  return roi;
}

/// Height of a detected box's top centre in the base frame [m].
double base_height_m(const Detection& d, const DetectedBox& b) {
  REQUIRE(d.boxes.size() > 0);
  return b.base_position ? b.base_position->z() : -1.0;
}

}  // namespace

TEST_CASE("cell: the cabinet's top is the highest plane in view - the region leaves it out") {
  const SynthFrame f = cell_frame();
  DetectionParams params;
  const Detection whole = detect(f.frame, kFormats, params);
  // Without a region the top plane is the cabinet's: no box of the load comes out.
  const bool load_found = whole.status == DetectionStatus::kOk && whole.boxes.size() == 6;
  CHECK_FALSE(load_found);

  params.roi = load_region();
  // The middle box of the near row shows seams along a fifth of its sides, and the joint fit
  // leaves its place along the row at its 50 mm prior: the position flag (test_level_flags.cpp)
  // flags that; this case is about the region.
  params.layout.refine.max_position_sigma_mm = 0.0;
  const Detection in_roi = detect(f.frame, kFormats, params);
  INFO(in_roi.message << " " << in_roi.ambiguity_reason);
  REQUIRE(in_roi.status == DetectionStatus::kOk);
  CHECK(in_roi.boxes.size() == 6);
  CHECK_FALSE(in_roi.ambiguous);
  for (const DetectedBox& b : in_roi.boxes) CHECK_FALSE(b.partly_unseen);
  for (const DetectedBox& b : in_roi.boxes) CHECK(base_height_m(in_roi, b) == Approx(kLoadTop_m).margin(0.01));
}

TEST_CASE("cell: a region whose floor lies above the cell's floor changes nothing on a lone pallet") {
  SynthCamera cam = camera_looking_at(kLoadTop_m, 8.0, 30.0);
  cam.distance_m = 2.4;
  SynthNoise noise;
  noise.dropout = 0.0;
  SynthFrame f = render_synthetic(grid_layer(3, 2, 0.004, kLoadTop_m, true), cam, noise);
  f.frame.T_base_camera = f.T_world_camera;
  DetectionParams params;
  const Detection whole = detect(f.frame, kFormats, params);
  REQUIRE(whole.status == DetectionStatus::kOk);
  REQUIRE_FALSE(whole.outline_unobserved);
  // The region starts 0.5 m above the floor: the floor below it still shows where the layer ends,
  // so no edge of the layer looks like an edge where the depth ends.
  params.roi = load_region();
  params.roi->min_m.z() = 0.5;
  const Detection in_roi = detect(f.frame, kFormats, params);
  INFO(in_roi.message);
  REQUIRE(in_roi.status == DetectionStatus::kOk);
  CHECK_FALSE(in_roi.outline_unobserved);
  REQUIRE(in_roi.boxes.size() == whole.boxes.size());
  for (const DetectedBox& b : in_roi.boxes) {
    double nearest_m = 1e9;
    for (const DetectedBox& w : whole.boxes) nearest_m = std::min(nearest_m, (b.center - w.center).norm());
    CHECK(nearest_m < 0.0005);
    CHECK_FALSE(b.partly_unseen);
  }
}

TEST_CASE("cell: a region in the camera frame needs no calibration") {
  SynthFrame f = cell_frame();
  DetectionParams params;
  // The load's box in the base frame, seen from the camera (its camera-frame bounding box).
  params.roi = camera_region(f.T_world_camera.inverse(), Eigen::Vector3d(-0.6, -0.4, 0.3),
                             Eigen::Vector3d(0.6, 0.4, kLoadTop_m + 0.1));
  f.frame.T_base_camera.reset();
  const Detection d = detect(f.frame, kFormats, params);
  INFO(d.message);
  REQUIRE(d.status == DetectionStatus::kOk);
  CHECK(d.boxes.size() == 6);
}

TEST_CASE("cell: a base-frame region on a frame without camera_to_base fails that frame, naming why") {
  SynthFrame f = cell_frame();
  f.frame.T_base_camera.reset();
  DetectionParams params;
  params.roi = load_region();
  const Detection d = detect(f.frame, kFormats, params);
  CHECK(d.status == DetectionStatus::kBadFrame);
  CHECK_THAT(d.message, Catch::Contains("camera_to_base"));
  CHECK(d.boxes.empty());
}

TEST_CASE("cell: with camera_to_base only a level plane is a layer") {
  SynthFrame f = cell_frame();
  DetectionParams params;
  // A region that does not depend on the calibration, so that only the plane rule changes below.
  params.roi = camera_region(f.T_world_camera.inverse(), load_region().min_m, load_region().max_m);
  REQUIRE(detect(f.frame, kFormats, params).status == DetectionStatus::kOk);

  // A calibration that says up is 12 deg away from the layers' normal: no level plane.
  const Eigen::Isometry3d tilted =
      Eigen::Isometry3d(Eigen::AngleAxisd(12.0 * M_PI / 180.0, Eigen::Vector3d::UnitX())) * f.T_world_camera;
  f.frame.T_base_camera = tilted;
  const Detection wrong_up = detect(f.frame, kFormats, params);
  CHECK(wrong_up.status == DetectionStatus::kNoPlane);
  CHECK_THAT(wrong_up.message, Catch::Contains("level plane"));

  // The same frame without a calibration: any plane facing the camera within max_tilt_deg.
  f.frame.T_base_camera.reset();
  CHECK(detect(f.frame, kFormats, params).status == DetectionStatus::kOk);

  // A wider tolerance accepts the tilted calibration again.
  f.frame.T_base_camera = tilted;
  params.plane.max_base_tilt_deg = 15.0;
  CHECK(detect(f.frame, kFormats, params).status == DetectionStatus::kOk);
}

namespace {

/// A 0.6 x 0.4 slab (top at top_z_m, standing on bottom_z_m) and a recipe by which it is one carton
/// or two side by side (no seam tells: the layout is in doubt).
const std::vector<BoxFormat> kSlabFormats = {{0.6, 0.4, "600x400"}, {0.4, 0.3, "400x300"}};

SynthBox slab(double bottom_z_m, double top_z_m) {
  SynthBox b;
  b.long_m = 0.6;
  b.short_m = 0.4;
  b.bottom_z_m = bottom_z_m;
  b.top_z_m = top_z_m;
  return b;
}

/// The scene's last box is the top level, seen from 1.5 m, tilted 5 deg, calibrated.
SynthFrame slab_frame(std::vector<SynthBox> boxes) {
  SynthScene scene;
  scene.boxes = std::move(boxes);
  scene.top = {scene.boxes.size() - 1};
  scene.top_z_m = scene.boxes.back().top_z_m;
  SynthCamera cam = camera_looking_at(scene.top_z_m, 5.0, 30.0);
  cam.distance_m = 1.5;
  SynthFrame f = render_synthetic(scene, cam, SynthNoise{});
  f.frame.T_base_camera = f.T_world_camera;
  return f;
}

}  // namespace

TEST_CASE("cell: a level too close above the lowest level in view is no empty pallet's deck") {
  // The slab on the floor. 0.15 m high it stands like a pallet's deck above the floor: empty.
  // 0.06 m high, no pallet is that low: the lowest level in view is no floor under a deck (a
  // camera's noise beyond its range, or a view without the floor), and the level is not called
  // empty.
  for (const double height_m : {0.15, 0.06}) {
    const SynthFrame f = slab_frame({slab(0.0, height_m)});
    const Detection d = detect(f.frame, kSlabFormats, DetectionParams{});
    CAPTURE(height_m, to_string(d.status), d.message, d.ambiguity_reason);
    CHECK((d.status == DetectionStatus::kEmpty) == (height_m > 0.1));
    CHECK_FALSE((d.status == DetectionStatus::kOk && !d.ambiguous));
  }
}

TEST_CASE("cell: the pallet's height decides the deck, not the level seen lowest") {
  // The slab on a wide level 0.15 m lower that fills the view (the next layer of cartons seen
  // from close by). Without a pallet height the wide level passes for the floor under a deck:
  // empty. With the pallet's height the slab stands far above the deck: never empty.
  SynthBox lower;
  lower.long_m = 3.0;
  lower.short_m = 3.0;
  lower.top_z_m = 0.85;
  const SynthFrame f = slab_frame({lower, slab(0.85, 1.0)});
  DetectionParams params;
  const Detection unknown_height = detect(f.frame, kSlabFormats, params);
  CAPTURE(to_string(unknown_height.status), unknown_height.message);
  REQUIRE(unknown_height.status ==
          DetectionStatus::kEmpty);  // the level below decides (the scene tests what it means to)

  params.pallet.top_z_m = 0.144;
  const Detection d = detect(f.frame, kSlabFormats, params);
  CAPTURE(to_string(d.status), d.message, d.ambiguity_reason);
  CHECK(d.status != DetectionStatus::kEmpty);
  CHECK_FALSE((d.status == DetectionStatus::kOk && !d.ambiguous));
}
