// The drift reference's life in the service (drift_keeper.hpp).
#include "drift_keeper.hpp"

#include <filesystem>

#include "palletd/frames/frame_io.hpp"

namespace palletd {

namespace {

bool same_pose(const std::optional<Eigen::Isometry3d>& a, const std::optional<Eigen::Isometry3d>& b) {
  return a.has_value() == b.has_value() && (!a || a->matrix() == b->matrix());
}

}  // namespace

Expected<DriftReference> DriftKeeper::reference_from(const Frame& frame) const {
  return DriftReference::from_frame(frame, roi_, params_);
}

std::string DriftKeeper::configure(const Config& config) {
  // A reload that changes neither the reference file nor the region keeps the reference (building
  // one takes about half a second at 640 x 480, between two triggers).
  std::error_code ec;
  const auto written = std::filesystem::last_write_time(config.health.drift_reference + ".depth.png", ec);
  if (reference_ && !ec && written == loaded_written_ && stem_ == config.health.drift_reference &&
      roi_ == config.detection.roi && same_pose(T_base_camera_, config.T_base_camera)) {
    return "drift reference " + stem_ + " kept";
  }
  stem_ = config.health.drift_reference;
  roi_ = config.detection.roi;
  T_base_camera_ = config.T_base_camera;
  reference_.reset();
  loaded_written_ = ec ? std::filesystem::file_time_type{} : written;
  if (stem_.empty()) {
    note_ = "no drift reference configured (health.drift_reference)";
    return note_;
  }
  if (!std::filesystem::exists(stem_ + ".depth.png", ec)) {
    note_ = "no drift reference yet: set one with palletctl drift --set or control bit 4 (" + stem_ + ")";
    return note_;
  }
  Expected<Frame> frame = read_frame(stem_);
  if (!frame) {
    note_ = "drift reference " + stem_ + ": " + frame.error();
    return note_;
  }
  if (T_base_camera_) frame->T_base_camera = T_base_camera_;
  Expected<DriftReference> reference = reference_from(*frame);
  if (!reference) {
    note_ = "drift reference " + stem_ + ": " + reference.error();
    return note_;
  }
  reference_ = std::make_shared<const DriftReference>(std::move(reference).value());
  note_.clear();
  return "drift reference " + stem_ + " loaded (" + std::to_string(reference_->points()) + " fixed points)";
}

Status DriftKeeper::set_reference(const Frame& frame) {
  if (stem_.empty()) return Error{"health.drift_reference is empty: no place to keep a reference"};
  Expected<DriftReference> reference = reference_from(frame);
  if (!reference) return Error{reference.error()};
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(stem_).parent_path(), ec);
  if (Status written = write_frame(stem_, frame); !written) return Error{stem_ + ": " + written.error()};
  loaded_written_ = std::filesystem::last_write_time(stem_ + ".depth.png", ec);
  reference_ = std::make_shared<const DriftReference>(std::move(reference).value());
  note_.clear();
  return {};
}

DriftReading DriftKeeper::measure(const Frame& frame) const {
  DriftReading reading;
  if (!reference_) {
    reading.note = note_;
    return reading;
  }
  reading.reference = true;
  const DriftEstimate estimate = measure_drift(frame, *reference_, params_);
  reading.measured = estimate.measured;
  reading.shift_mm = estimate.shift_mm;
  reading.angle_deg = estimate.angle_deg;
  reading.note = estimate.measured ? estimate.observability.note : estimate.message;
  return reading;
}

}  // namespace palletd
