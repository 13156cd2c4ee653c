// Camera mount drift (palletd/detection/drift.hpp) on simulated cells: a reference frame at
// commissioning, later frames from a camera that was bumped, a changed load, a floor alone.
#include <cmath>

#include <catch2/catch.hpp>

#include "palletd/detection/drift.hpp"
#include "palletd/sim/sim.hpp"

using namespace palletd;

namespace {

constexpr std::uint64_t kReferenceNoise = 100, kLaterNoise = 200;  // render seeds

sim::SimBox standing_carton(const Eigen::Vector2d& center_m, double long_m, double short_m, double top_z_m) {
  sim::SimBox b;
  b.center = center_m;
  b.long_m = long_m;
  b.short_m = short_m;
  b.top_z_m = top_z_m;
  b.reflectance = 0.4;
  return b;
}

/// A EUR pallet with two layers of 400 x 300 x 250 boxes in a simulated cell (`family`), a 1.6 m
/// cabinet off its +x end and two 1.8 m posts; the camera 3.3 m above the floor, looking down at
/// about 15 degrees. kIsolated gets no cabinet and no posts: the floor alone outside the load.
sim::Scene make_cell(sim::SceneFamily family, const std::string& profile_name = "o3d303") {
  const sim::SensorProfile profile = *sim::profile_by_name(profile_name);
  sim::ScenarioOptions options;
  options.scene = family;
  options.pattern = sim::PatternFamily::kBlock;
  options.formats = {*sim::parse_format("400x300x250")};
  options.lower_layers_min = options.lower_layers_max = 1;
  sim::Scene scene = *sim::make_scene(options, profile, 3);
  if (family != sim::SceneFamily::kIsolated) {
    scene.boxes.push_back(standing_carton(Eigen::Vector2d(1.3, -0.2), 0.6, 0.5, 1.6));
    scene.boxes.push_back(standing_carton(Eigen::Vector2d(-1.0, 0.9), 0.1, 0.1, 1.8));
    scene.boxes.push_back(standing_carton(Eigen::Vector2d(0.9, 0.9), 0.1, 0.1, 1.8));
  }
  scene.T_world_camera =
      sim::camera_looking_at(Eigen::Vector3d(-0.4, -0.5, 3.3), Eigen::Vector3d(0.2, 0.1, 0.0));
  return scene;
}

/// The load volume (world = base frame): the pallet grown by 0.1 m, up to 0.3 m above the load.
RegionOfInterest load_volume(const sim::Scene& scene) {
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kBase;
  roi.min_m = Eigen::Vector3d(-0.5 * scene.pallet_long_m - 0.1, -0.5 * scene.pallet_short_m - 0.1, 0.1);
  roi.max_m =
      Eigen::Vector3d(0.5 * scene.pallet_long_m + 0.1, 0.5 * scene.pallet_short_m + 0.1, scene.top_z_m + 0.3);
  return roi;
}

Frame render(const sim::Scene& scene, std::uint64_t noise_seed, const std::string& profile_name = "o3d303") {
  return sim::render(scene, *sim::profile_by_name(profile_name), noise_seed).frame;
}

/// The camera turned by `angle_deg` about `axis` (camera frame, about its own origin) and shifted
/// by `shift_m`: T_reference_camera of the moved camera.
Eigen::Isometry3d bump(double angle_deg, const Eigen::Vector3d& axis, const Eigen::Vector3d& shift_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(angle_deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
  T.translation() = shift_m;
  return T;
}

/// A frame from the bumped camera whose calibration still says the old pose.
Frame render_bumped(const sim::Scene& scene, const Eigen::Isometry3d& T_reference_camera,
                    const std::string& profile_name = "o3d303") {
  sim::Scene moved = scene;
  moved.T_world_camera = scene.T_world_camera * T_reference_camera;
  Frame frame = render(moved, kLaterNoise, profile_name);
  frame.T_base_camera = scene.T_world_camera;  // stale
  return frame;
}

double angle_deg(const Eigen::Isometry3d& T) { return Eigen::AngleAxisd(T.linear()).angle() * 180.0 / M_PI; }

DriftReference reference_of(const sim::Scene& scene, const std::string& profile_name = "o3d303") {
  const Expected<DriftReference> reference =
      DriftReference::from_frame(render(scene, kReferenceNoise, profile_name), load_volume(scene));
  INFO((reference ? std::string() : reference.error()));
  REQUIRE(reference);
  return *reference;
}

}  // namespace

TEST_CASE("drift: an unmoved camera measures no drift", "[drift]") {
  const sim::Scene scene = make_cell(sim::SceneFamily::kCell);
  const DriftReference reference = reference_of(scene);
  CHECK(reference.observability().dofs == 6);
  const DriftEstimate e = measure_drift(render(scene, kLaterNoise), reference);
  INFO(e.message << " / " << e.observability.note);
  REQUIRE(e.measured);
  CHECK(e.shift_mm < 2.0);
  CHECK(e.angle_deg < 0.1);
  CHECK(e.points >= 1000);
  CHECK(e.matched_share > 0.9);
}

TEST_CASE("drift: a camera turned 1 degree and shifted 10 mm, its calibration stale", "[drift]") {
  const sim::Scene scene = make_cell(sim::SceneFamily::kCell, "blaze101");
  const DriftReference reference = reference_of(scene, "blaze101");
  const Eigen::Isometry3d truth =
      bump(1.0, Eigen::Vector3d(0.3, 1.0, 0.2), Eigen::Vector3d(6.0, -5.0, 6.2) * 1e-3);
  const DriftEstimate e = measure_drift(render_bumped(scene, truth, "blaze101"), reference);
  INFO(e.message << " / " << e.observability.note);
  REQUIRE(e.measured);
  REQUIRE(e.observability.dofs == 6);
  // A 640 x 480 time-of-flight camera (blaze101 profile: about 3 mm of noise per 2 x 2 block at
  // 3.5 m; 7000 matched blocks) pins the floor's height and tilt to about 0.05 mm and 0.005
  // degrees. The shifts along the floor and the turn about its normal rest on the cabinet's and the
  // posts' sides, about 1 % of the floor's information: their spread is about 0.5 mm at the points
  // and 0.02 degrees (over eight simulated cells: 0.1-0.9 mm, at most 0.02 degrees). 1.5 mm and 0.1
  // degrees leave room for that. The o3d303 profile (352 x 264, 7 mm) spreads about twice as far:
  // up to 2.4 mm and 0.14 degrees over the same cells.
  const Eigen::Isometry3d error = truth.inverse() * e.T_reference_camera;
  CHECK(error.translation().norm() * 1000.0 < 1.5);
  CHECK(angle_deg(error) < 0.1);
  CHECK(e.shift_mm == Approx(truth.translation().norm() * 1000.0).margin(1.5));
  CHECK(e.angle_deg == Approx(1.0).margin(0.1));
}

TEST_CASE("drift: a camera turned about its own x axis where one turn is barely constrained", "[drift]") {
  // A generated cell whose fixed geometry barely constrains a turn about a vertical axis through
  // the cabinet (about 0.3 % of the floor's information). The camera's own turn is measured as a
  // turn, not as a turn about the fixed points' far centroid plus a shift of several centimetres
  // with a part of it left out.
  sim::ScenarioOptions options;
  options.scene = sim::SceneFamily::kCell;
  const sim::SensorProfile profile = *sim::profile_by_name("o3d303");
  const sim::Scene scene = *sim::make_scene(options, profile, 11);
  RegionOfInterest roi;
  roi.frame = RegionOfInterest::Frame::kBase;
  roi.min_m = scene.roi_min_m;
  roi.max_m = scene.roi_max_m;
  const Expected<DriftReference> reference = DriftReference::from_frame(render(scene, 1), roi);
  REQUIRE(reference);
  const Eigen::Isometry3d truth = bump(1.0, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero());
  const DriftEstimate e = measure_drift(render_bumped(scene, truth), *reference);
  INFO(e.message << " / " << e.observability.note);
  REQUIRE(e.measured);
  CHECK(angle_deg(truth.inverse() * e.T_reference_camera) < 0.1);
  CHECK(e.angle_deg == Approx(1.0).margin(0.05));
}

TEST_CASE("drift: another load on the pallet and a person in the cell leave it at zero", "[drift]") {
  const sim::Scene scene = make_cell(sim::SceneFamily::kCell);
  const DriftReference reference = reference_of(scene);
  sim::Scene later = scene;
  for (std::size_t k = 0; k < later.top_layer.size(); ++k) {
    sim::SimBox& box = later.boxes[later.top_layer[k]];
    if (k % 2 == 0)
      box.top_z_m += 0.2;  // taller boxes
    else
      box.yaw_rad += 0.3;  // turned boxes
  }
  // A person beside the pallet, outside the load volume, where the reference saw the floor.
  later.boxes.push_back(standing_carton(Eigen::Vector2d(0.2, -0.8), 0.45, 0.3, 1.75));
  const DriftEstimate e = measure_drift(render(later, kLaterNoise), reference);
  INFO(e.message << " / " << e.observability.note);
  REQUIRE(e.measured);
  CHECK(e.shift_mm < 2.0);
  CHECK(e.angle_deg < 0.1);
}

TEST_CASE("drift: a floor alone shows the tilt, not a shift along it", "[drift]") {
  const sim::Scene scene = make_cell(sim::SceneFamily::kIsolated);
  const DriftReference reference = reference_of(scene);
  const DriftObservability& seen = reference.observability();
  INFO(seen.note);
  CHECK(seen.dofs == 3);
  // The camera looks down: its x axis lies along the floor, its z axis nearly along the normal.
  CHECK_FALSE(seen.axes[0]);  // shift along x
  CHECK_FALSE(seen.axes[5]);  // turn about z
  CHECK(seen.axes[2]);        // shift along z: the height
  CHECK(seen.axes[3]);        // turns about x and y: the tilt
  CHECK(seen.axes[4]);
  CHECK(seen.note.find("shift along x") != std::string::npos);

  const Eigen::Isometry3d truth =
      bump(0.5, Eigen::Vector3d(1.0, 0.2, 0.0), Eigen::Vector3d(4.0, 3.0, 2.0) * 1e-3);
  const DriftEstimate e = measure_drift(render_bumped(scene, truth), reference);
  INFO(e.message << " / " << e.observability.note);
  REQUIRE(e.measured);
  CHECK(e.observability.dofs == 3);
  // What is measured is right: floor points of the new view land on the reference's floor. The
  // floor seen by the o3d303 (about 7 mm of noise per point, normals from 48 neighbours whose
  // errors are shared) gives the tilt to about 0.02 degrees, 0.7 mm at the corners 2 m away.
  const Eigen::Isometry3d T_world_reference = scene.T_world_camera;
  const Eigen::Isometry3d T_world_current = T_world_reference * truth;
  const Eigen::Vector3d up_reference = T_world_reference.linear().transpose() * Eigen::Vector3d::UnitZ();
  for (const Eigen::Vector3d& q_world : {Eigen::Vector3d(1.6, 1.2, 0.0), Eigen::Vector3d(-1.6, 1.2, 0.0),
                                         Eigen::Vector3d(1.6, -1.2, 0.0), Eigen::Vector3d(-1.6, -1.2, 0.0)}) {
    const Eigen::Vector3d p_reference = e.T_reference_camera * (T_world_current.inverse() * q_world);
    CHECK(std::abs((T_world_reference * p_reference).z()) * 1000.0 < 2.0);
  }
  const Eigen::Vector3d up_current = T_world_current.linear().transpose() * Eigen::Vector3d::UnitZ();
  CHECK(std::acos(std::min(1.0, (e.T_reference_camera.linear() * up_current).dot(up_reference))) * 180.0 /
            M_PI <
        0.05);
}

TEST_CASE("drift: not measured without a region of interest or with too little of the cell in view",
          "[drift]") {
  const sim::Scene scene = make_cell(sim::SceneFamily::kCell);
  const Frame frame = render(scene, kReferenceNoise);
  const Expected<DriftReference> no_roi = DriftReference::from_frame(frame, std::nullopt);
  REQUIRE_FALSE(no_roi);
  CHECK(no_roi.error().find("region of interest") != std::string::npos);

  RegionOfInterest everything = load_volume(scene);
  everything.min_m = Eigen::Vector3d(-10.0, -10.0, 0.1);
  everything.max_m = Eigen::Vector3d(10.0, 10.0, 3.0);
  const Expected<DriftReference> all_load = DriftReference::from_frame(frame, everything);
  REQUIRE_FALSE(all_load);
  CHECK(all_load.error().find("fixed points") != std::string::npos);

  const DriftEstimate empty = measure_drift(frame, DriftReference());
  CHECK_FALSE(empty.measured);
  CHECK(empty.message.find("no drift reference") != std::string::npos);

  Frame blind = frame;
  std::fill(blind.depth.begin(), blind.depth.end(), 0);
  const DriftEstimate hidden = measure_drift(blind, reference_of(scene));
  CHECK_FALSE(hidden.measured);
  CHECK(hidden.message.find("fixed points") != std::string::npos);
}
