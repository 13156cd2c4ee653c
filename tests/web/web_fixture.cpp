#include "web_fixture.hpp"

#include <cmath>
#include <stdexcept>

#include "palletd/frames/frame_io.hpp"
#include "synthetic_scene.hpp"

namespace palletd::testing {

namespace {

Frame synthetic_frame() {
  SynthScene scene = grid_layer(3, 3, 0.006, 1.0, true);
  SynthCamera camera;
  camera.distance_m = 2.0;
  camera.look_at = Eigen::Vector3d(0.0, 0.0, scene.top_z_m);
  camera.tilt_deg = 4.0;
  SynthNoise noise;
  noise.seed = 11;
  SynthFrame synth = render_synthetic(scene, camera, noise);
  Frame frame = std::move(synth.frame);
  frame.T_base_camera = synth.T_world_camera;  // the pallet frame stands in for the robot base
  frame.camera_id = "synthetic-0001";
  frame.sequence = 42;
  return frame;
}

}  // namespace

WebFixture::WebFixture(const std::string& frame_stem) {
  Frame frame;
  if (frame_stem.empty()) {
    frame = synthetic_frame();
  } else {
    Expected<Frame> read = read_frame(frame_stem);
    if (!read) throw std::runtime_error(read.error());
    frame = std::move(read.value());
  }
  BoxFormat f315{0.315, 0.232, "F315"};
  BoxFormat f400{0.400, 0.300, "F400"};
  recipes_ = {RecipeInfo{1, "mixed 315/400", {f315, f400}}, RecipeInfo{2, "only 400", {f400}}};

  auto snapshot = std::make_shared<ResultSnapshot>();
  snapshot->trigger_seq = 7;
  snapshot->request_id = 1234;
  snapshot->recipe = 1;
  snapshot->detection = detect(frame, recipes_[0].formats, DetectionParams{});
  snapshot->frame = std::make_shared<const Frame>(std::move(frame));
  snapshot->latency_ms = 85.0;
  snapshot->time = std::chrono::system_clock::now();
  first_ = snapshot;

  health.threads_alive = true;
  health.camera_ok = true;
  health.camera_state = "streaming";
  health.camera_id = first_->frame->camera_id;
  health.triggers = 7;
  health.results = 7;
  health.failures = 0;
  health.frames = 7;
  health.reconnects = 2;
  health.grab_timeouts = 5;
  health.modbus_port = 1502;
  health.modbus_connections = 1;
  health.cell_health.frames = 7;
  health.cell_health.invalid_fraction = 0.04;
  health.cell_health.warnings = modbus::kHealthDrift | modbus::kHealthDriftReference | modbus::kHealthDriftMeasured;
  health.cell_health.drift_reference = true;
  health.cell_health.drift_measured = true;
  health.cell_health.drift_shift_mm = 12.5;
  health.cell_health.drift_angle_deg = 0.4;

  latest_ = first_;
  image_ = encode(*first_, modbus::kStReady | modbus::kStResultReady | modbus::kStCameraOk);
}

modbus::RegisterImage WebFixture::encode(const ResultSnapshot& s, std::uint16_t status_word) const {
  modbus::ResultRecord rec;
  rec.request_id = s.request_id;
  rec.recipe = s.recipe;
  rec.status = s.detection.status != DetectionStatus::kOk ? modbus::ResultStatus::kFailed
               : s.detection.boxes.empty()               ? modbus::ResultStatus::kNoBoxes
                                                         : modbus::ResultStatus::kOk;
  rec.boxes_found = static_cast<std::uint16_t>(s.detection.boxes.size());
  for (const auto& b : s.detection.boxes) {
    modbus::BoxRecord r;
    const Eigen::Vector3d p = b.base_position.value_or(b.center);
    r.x_m = p.x(), r.y_m = p.y(), r.z_m = p.z();
    r.yaw_deg = b.base_yaw_deg.value_or(0.0);
    r.format = static_cast<std::uint16_t>(b.format);
    r.score = b.score;
    r.pick_index = static_cast<std::uint16_t>(b.pick_index + 1);
    rec.boxes.push_back(r);
  }
  rec.ambiguous = s.detection.ambiguous;
  rec.coverage = s.detection.coverage;
  const auto total = s.detection.timing_ms.find("total");
  rec.processing_ms = total != s.detection.timing_ms.end() ? total->second : 0.0;

  modbus::StatusRecord st;
  st.status_word = status_word;
  st.active_recipe = s.recipe;
  st.acquisition_id = static_cast<std::uint16_t>(s.trigger_seq);
  st.result_id = static_cast<std::uint16_t>(s.trigger_seq);
  st.last_request_id = s.request_id;
  st.missed_triggers = 3;
  st.processing_ms = rec.processing_ms;
  st.latency_ms = s.latency_ms;
  st.frames_grabbed = 7;
  st.camera_reconnects = 2;
  st.camera_faults.grab_timeouts = 5;
  st.camera_faults.resent_packets = 70000;  // needs both words
  st.health.flags = modbus::kHealthDrift | modbus::kHealthDriftReference | modbus::kHealthDriftMeasured;
  st.health.frames = 7;
  st.health.invalid_fraction = 0.04;
  st.health.drift_shift_mm = 12.5;
  st.health.drift_angle_deg = 0.4;
  modbus::RegisterImage image{};
  modbus::encode_status(st, modbus::WordOrder::kHighWordFirst, image);
  modbus::encode_result(rec, static_cast<std::uint16_t>(s.trigger_seq), modbus::WordOrder::kHighWordFirst, image);
  image[modbus::kRegControlWord] = modbus::kCtlResultAck;
  image[modbus::kRegRecipe] = s.recipe;
  image[modbus::kRegRequestId] = s.request_id;
  return image;
}

StatusSource WebFixture::source() {
  StatusSource src;
  src.latest = [this] { return latest(); };
  src.health = [this] { return health; };
  src.registers = [this] {
    std::lock_guard<std::mutex> lock(mutex_);
    return image_;
  };
  src.recipes = [this] { return recipes_; };
  src.request_snapshot = [this]() -> Status {
    ++snapshot_requests;
    return {};
  };
  return src;
}

void WebFixture::set_latest(std::shared_ptr<const ResultSnapshot> snapshot) {
  std::lock_guard<std::mutex> lock(mutex_);
  latest_ = std::move(snapshot);
}

std::shared_ptr<const ResultSnapshot> WebFixture::latest() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

void WebFixture::set_registers(const modbus::RegisterImage& image) {
  std::lock_guard<std::mutex> lock(mutex_);
  image_ = image;
}

}  // namespace palletd::testing
