// The camera's drift reference as the service keeps it: loaded from its frame file at start and
// on reload, replaced on request (control bit 4), compared with every triggered frame. Pipeline
// thread only.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "palletd/config/config.hpp"
#include "palletd/core/expected.hpp"
#include "palletd/core/frame.hpp"
#include "palletd/detection/drift.hpp"

#include "health_monitor.hpp"

namespace palletd {

class DriftKeeper {
 public:
  /// Takes the reference's path and the region of interest from `config` and loads the reference
  /// frame when its file exists (no file: no reference, not an error); keeps the loaded one when
  /// neither changed. Returns what happened, for the log.
  std::string configure(const Config& config);
  /// Makes `frame` the reference: checks it, writes it to the configured path, keeps it.
  Status set_reference(const Frame& frame);
  /// The camera's pose against the reference in `frame`.
  [[nodiscard]] DriftReading measure(const Frame& frame) const;

 private:
  Expected<DriftReference> reference_from(const Frame& frame) const;

  std::string stem_;
  std::optional<RegionOfInterest> roi_;
  std::optional<Eigen::Isometry3d> T_base_camera_;  ///< the configuration's camera_to_base
  DriftParams params_;
  std::shared_ptr<const DriftReference> reference_;
  std::filesystem::file_time_type loaded_written_{};  ///< the reference file's time when loaded
  std::string note_;  ///< why there is no reference
};

}  // namespace palletd
