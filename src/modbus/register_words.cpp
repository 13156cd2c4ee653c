// Register contents in words (register_words.hpp).
#include "palletd/modbus/register_words.hpp"

#include <string>

namespace palletd::modbus {

std::string bits_in_words(std::uint16_t word, const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if ((word & (1u << i)) == 0) continue;
    if (!out.empty()) out += ", ";
    out += names[i];
  }
  return out.empty() ? "none set" : out;
}

namespace {

const char* detection_failure_text(std::uint16_t detail) {
  switch (static_cast<modbus::DetectionFailure>(detail)) {
    case modbus::DetectionFailure::kNoPlane:
      return "no plane found in the frame";
    case modbus::DetectionFailure::kNoLayer:
      return "no top layer found";
    case modbus::DetectionFailure::kNoLayout:
      return "no box layout fits the layer";
    case modbus::DetectionFailure::kBadFrame:
      return "the frame is unusable";
    case modbus::DetectionFailure::kRecipeMismatch:
      return "the cartons do not match the recipe (register 532: the recipe that fits)";
    case modbus::DetectionFailure::kUnknown:
      break;
  }
  return "reason unknown";
}

const char* pick_check_failure_text(std::uint16_t detail) {
  switch (static_cast<modbus::PickCheckFailure>(detail)) {
    case modbus::PickCheckFailure::kNoLayout:
      return "the result in the block has no boxes to check against (trigger a detection)";
    case modbus::PickCheckFailure::kNothingPicked:
      return "registers 4 and 5 name no box or group of the result in the block";
    case modbus::PickCheckFailure::kBadFrame:
      return "the frame after the pick cannot be compared with the last one";
  }
  return "reason unknown";
}

}  // namespace

const char* error_name(ErrorCode code) {
  switch (code) {
    case ErrorCode::kNone:
      return "no error";
    case ErrorCode::kFrameTimeout:
      return "frame timeout";
    case ErrorCode::kDetectionTimeout:
      return "detection timeout";
    case ErrorCode::kDetectionFailed:
      return "detection failed";
    case ErrorCode::kCameraDisconnected:
      return "camera disconnected";
    case ErrorCode::kUnknownRecipe:
      return "unknown recipe";
    case ErrorCode::kPlcHeartbeatLost:
      return "PLC heartbeat lost";
    case ErrorCode::kInternal:
      return "internal error";
    case ErrorCode::kPickCheckFailed:
      return "pick check failed";
  }
  return "unknown error code";
}

std::string error_sentence(ErrorCode code, std::uint16_t detail) {
  switch (code) {
    case ErrorCode::kNone:
      return "No error.";
    case ErrorCode::kFrameTimeout:
      return "No frame was captured after the trigger within the frame timeout.";
    case ErrorCode::kDetectionTimeout:
      return "The detection took longer than the detection timeout.";
    case ErrorCode::kDetectionFailed:
      return std::string("The detection failed: ") + detection_failure_text(detail) + ".";
    case ErrorCode::kCameraDisconnected:
      return "The camera is disconnected (" + std::to_string(detail) + " reconnect attempts so far).";
    case ErrorCode::kUnknownRecipe:
      return "The PLC asked for recipe " + std::to_string(detail) + ", which is not configured.";
    case ErrorCode::kPlcHeartbeatLost:
      return "The PLC heartbeat (register 3) stopped changing.";
    case ErrorCode::kInternal:
      return "Internal error: see the log (journalctl -u palletd).";
    case ErrorCode::kPickCheckFailed:
      return std::string("The pick check could not run: ") + pick_check_failure_text(detail) + ".";
  }
  return "Unknown error code " + std::to_string(static_cast<unsigned>(code)) + ".";
}

const std::vector<std::string>& status_bit_names() {
  static const std::vector<std::string> names{
      "Ready",         "Busy",     "TriggerAck",      "ResultReady",  "Error",
      "MissedTrigger", "CameraOK", "HeartbeatToggle", "ResultOverrun", "HealthWarning",
      "DriftWarning"};
  return names;
}

const std::vector<std::string>& control_bit_names() {
  static const std::vector<std::string> names{"Trigger", "ResultAck", "ClearError", "SaveSnapshot",
                                                   "SetDriftReference", "PickCheck"};
  return names;
}

}  // namespace palletd::modbus
