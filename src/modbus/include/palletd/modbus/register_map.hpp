// palletd modbus: the register map of interface version 1 (docs/register-map.md) as pure
// encode/decode functions. This is the only place that scales metres to 0.1 mm, degrees to
// 0.01 degree and 0..1 scores to 0..1000. No I/O, no threads; every function is reentrant.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace palletd::modbus {

// ---- addresses (0-based protocol addresses; holding register N is 4xxxx register N + 1) ----
inline constexpr std::uint16_t kControlStart = 0;
inline constexpr std::uint16_t kControlCount = 16;   ///< 0..15, written by the PLC
inline constexpr std::uint16_t kStatusStart = 100;
inline constexpr std::uint16_t kStatusCount = 30;    ///< 100..129, read-only (100..117 until 118..129 were added)
inline constexpr std::uint16_t kResultStart = 200;
inline constexpr std::uint16_t kResultHeaderCount = 10;  ///< 200..209
inline constexpr std::uint16_t kBoxStart = 210;
inline constexpr std::uint16_t kBoxStride = 10;
inline constexpr std::uint16_t kMaxBoxes = 32;
inline constexpr std::uint16_t kResultIdCopy = 530;  ///< copy of register 200
/// Layout confidence 0..1000 (Detection::layout_confidence), written with the result block.
inline constexpr std::uint16_t kRegLayoutConfidence = 531;
/// With a recipe mismatch (error detail 8): the number of the configured recipe whose cartons
/// the frame shows best, 0 when none fits (or none was sought), written with the result block.
inline constexpr std::uint16_t kRegBestRecipe = 532;
/// 200..532: the result block, the layout confidence and the best recipe after it (one
/// consistent read each).
inline constexpr std::uint16_t kResultCount = kRegBestRecipe - kResultStart + 1;
// pick block 540..902, read-only: written with each result (same image update), cleared with it
inline constexpr std::uint16_t kPickStart = 540;
inline constexpr std::uint16_t kPickHeaderCount = 10;  ///< 540..549 (545..549 reserved, read 0)
inline constexpr std::uint16_t kGroupStart = 550;
inline constexpr std::uint16_t kGroupStride = 10;
inline constexpr std::uint16_t kMaxGroups = 32;
inline constexpr std::uint16_t kPickStatusStart = 870;  ///< 870 + i: PickStatus of box slot i
inline constexpr std::uint16_t kPickIdCopy = 902;       ///< copy of register 200
inline constexpr std::uint16_t kPickCount = kPickIdCopy - kPickStart + 1;  ///< 540..902
// size block 910..974, read-only: each reported box's top face (the format's size, or the size
// measured on the frame with a size-range recipe), written with each result
inline constexpr std::uint16_t kSizeStart = 910;  ///< 910 + 2 i: long side, 911 + 2 i: short side [0.1 mm]
inline constexpr std::uint16_t kSizeStride = 2;
inline constexpr std::uint16_t kSizeIdCopy = 974;  ///< copy of register 200
inline constexpr std::uint16_t kSizeCount = kSizeIdCopy - kSizeStart + 1;  ///< 910..974
inline constexpr std::uint16_t kRegisterCount = kSizeIdCopy + 1;          ///< 0..974
static_assert(kSizeIdCopy == kSizeStart + kSizeStride * kMaxBoxes);
static_assert(kGroupStart == kPickStart + kPickHeaderCount);
static_assert(kPickStatusStart == kGroupStart + kGroupStride * kMaxGroups);
static_assert(kPickIdCopy == kPickStatusStart + kMaxBoxes);
inline constexpr std::uint16_t kInterfaceVersion = 1;
inline constexpr std::uint32_t kTestPattern = 0x12345678u;

// control block
inline constexpr std::uint16_t kRegControlWord = 0;
inline constexpr std::uint16_t kRegRecipe = 1;
inline constexpr std::uint16_t kRegRequestId = 2;
inline constexpr std::uint16_t kRegPlcHeartbeat = 3;
inline constexpr std::uint16_t kRegPickedBox = 4;    ///< box slot + 1 the last pick took (0 = none); latched with PickCheck
inline constexpr std::uint16_t kRegPickedGroup = 5;  ///< group slot + 1 the last pick took (0 = none); latched with PickCheck
// status block
inline constexpr std::uint16_t kRegStatusWord = 100;
inline constexpr std::uint16_t kRegErrorCode = 101;
inline constexpr std::uint16_t kRegErrorDetail = 102;
inline constexpr std::uint16_t kRegHeartbeat = 103;
inline constexpr std::uint16_t kRegActiveRecipe = 104;
inline constexpr std::uint16_t kRegAcquisitionId = 105;
inline constexpr std::uint16_t kRegStatusResultId = 106;
inline constexpr std::uint16_t kRegLastRequestId = 107;
inline constexpr std::uint16_t kRegInterfaceVersion = 108;
inline constexpr std::uint16_t kRegFormatFlags = 109;
inline constexpr std::uint16_t kRegTestPattern = 110;  ///< 110-111
inline constexpr std::uint16_t kRegMissedTriggers = 112;
inline constexpr std::uint16_t kRegProcessingMs = 113;
inline constexpr std::uint16_t kRegLatencyMs = 114;
inline constexpr std::uint16_t kRegFramesGrabbed = 115;  ///< 115-116
inline constexpr std::uint16_t kRegCameraReconnects = 117;
// camera fault counters (uint32 each, two registers in the configured word order; wrap at 2^32)
inline constexpr std::uint16_t kRegIncompleteFrames = 118;  ///< 118-119
inline constexpr std::uint16_t kRegGrabTimeouts = 120;      ///< 120-121
inline constexpr std::uint16_t kRegDroppedFrames = 122;     ///< 122-123
inline constexpr std::uint16_t kRegCameraLosses = 124;      ///< 124-125
inline constexpr std::uint16_t kRegCameraRestarts = 126;    ///< 126-127
inline constexpr std::uint16_t kRegResentPackets = 128;     ///< 128-129
// result extension 130..139: written with each result (same image update), cleared with it
inline constexpr std::uint16_t kResultExtStart = 130;
inline constexpr std::uint16_t kResultExtCount = 10;        ///< 130..139
inline constexpr std::uint16_t kRegResultDetail = 130;      ///< ResultDetail
inline constexpr std::uint16_t kRegLayerInfoFlags = 131;    ///< kLayer* bits: which of 132..134 are known
inline constexpr std::uint16_t kRegHeightAbovePallet = 132; ///< 132-133, int32 0.1 mm
inline constexpr std::uint16_t kRegLayersRemaining = 134;
// pick check (135..139): set on a result that answers a PickCheck, 0 on a detection's result
inline constexpr std::uint16_t kRegCheckResult = 135;       ///< CheckResult
inline constexpr std::uint16_t kRegCheckBoxesGone = 136;    ///< boxes gone since the result checked against
inline constexpr std::uint16_t kRegCheckBoxesMoved = 137;   ///< boxes left that moved (new poses in their slots)
inline constexpr std::uint16_t kRegCheckMovedSlot = 138;    ///< slot + 1 of the box that moved most (0 = none)
inline constexpr std::uint16_t kRegCheckLargestMove = 139;  ///< its move [0.1 mm], saturated at 65535
// Modbus connection block 140..145, read-only: the server's own connection counters
inline constexpr std::uint16_t kConnectionStart = 140;
inline constexpr std::uint16_t kConnectionCount = 6;        ///< 140..145
inline constexpr std::uint16_t kRegConnectionsEvicted = 140;  ///< 140-141
inline constexpr std::uint16_t kRegConnectionsRefused = 142;  ///< 142-143
inline constexpr std::uint16_t kRegOpenConnections = 144;
inline constexpr std::uint16_t kRegMaxConnections = 145;
// cell health block 146..155, read-only: the health window's means and the camera's drift
inline constexpr std::uint16_t kHealthStart = 146;
inline constexpr std::uint16_t kHealthCount = 10;           ///< 146..155 (154..155 reserved, read 0)
inline constexpr std::uint16_t kRegHealthFlags = 146;       ///< kHealth* bits
inline constexpr std::uint16_t kRegHealthFrames = 147;      ///< frames in the window
inline constexpr std::uint16_t kRegInvalidPermille = 148;
inline constexpr std::uint16_t kRegFlyingPermille = 149;
inline constexpr std::uint16_t kRegSaturatedPermille = 150;
inline constexpr std::uint16_t kRegNoiseRatio = 151;        ///< plane noise over the model's, x100
inline constexpr std::uint16_t kRegDriftShift = 152;        ///< 0.1 mm, saturated at 65535
inline constexpr std::uint16_t kRegDriftAngle = 153;        ///< 0.01 deg, saturated at 65535
// result block
inline constexpr std::uint16_t kRegResultId = 200;
inline constexpr std::uint16_t kRegResultRequestId = 201;
inline constexpr std::uint16_t kRegResultStatus = 202;
inline constexpr std::uint16_t kRegBoxesFound = 203;
inline constexpr std::uint16_t kRegBoxesReported = 204;
inline constexpr std::uint16_t kRegRecipeUsed = 205;
inline constexpr std::uint16_t kRegResultFlags = 206;
inline constexpr std::uint16_t kRegLayerZ = 207;  ///< 207-208
inline constexpr std::uint16_t kRegCoverage = 209;
// pick block header
inline constexpr std::uint16_t kRegPickResultId = 540;   ///< same as 200
inline constexpr std::uint16_t kRegPickFlags = 541;      ///< kPick* bits
inline constexpr std::uint16_t kRegGroupsFound = 542;
inline constexpr std::uint16_t kRegGroupsReported = 543;  ///< groups in 550 + 10 g
inline constexpr std::uint16_t kRegPickableBoxes = 544;   ///< among all boxes found

// control word bits (register 0)
inline constexpr std::uint16_t kCtlTrigger = 1u << 0;
inline constexpr std::uint16_t kCtlResultAck = 1u << 1;
inline constexpr std::uint16_t kCtlClearError = 1u << 2;
inline constexpr std::uint16_t kCtlSaveSnapshot = 1u << 3;
inline constexpr std::uint16_t kCtlSetDriftReference = 1u << 4;
inline constexpr std::uint16_t kCtlPickCheck = 1u << 5;
// status word bits (register 100)
inline constexpr std::uint16_t kStReady = 1u << 0;
inline constexpr std::uint16_t kStBusy = 1u << 1;
inline constexpr std::uint16_t kStTriggerAck = 1u << 2;
inline constexpr std::uint16_t kStResultReady = 1u << 3;
inline constexpr std::uint16_t kStError = 1u << 4;
inline constexpr std::uint16_t kStMissedTrigger = 1u << 5;
inline constexpr std::uint16_t kStCameraOk = 1u << 6;
inline constexpr std::uint16_t kStHeartbeatToggle = 1u << 7;
inline constexpr std::uint16_t kStResultOverrun = 1u << 8;
/// A cell health mean is beyond its limit (register 146 bits 0..3 say which).
inline constexpr std::uint16_t kStHealthWarning = 1u << 9;
/// The camera moved against its drift reference beyond health.max_drift_mm / _deg.
inline constexpr std::uint16_t kStDriftWarning = 1u << 10;
// format flags (register 109)
inline constexpr std::uint16_t kFmtLowWordFirst = 1u << 0;
inline constexpr std::uint16_t kFmtCameraFrame = 1u << 1;
// result flags (register 206)
inline constexpr std::uint16_t kResAmbiguous = 1u << 0;
inline constexpr std::uint16_t kResBudgetExhausted = 1u << 1;
inline constexpr std::uint16_t kResLayerClipped = 1u << 2;
/// Part of the layer's outline runs along pixels without depth: the layer may go on unseen there.
inline constexpr std::uint16_t kResOutlineUnobserved = 1u << 3;
/// The layer's height above the pallet is not a whole number of box heights (bit0 is set too).
inline constexpr std::uint16_t kResHeightOffLayers = 1u << 4;
/// The recipe is a size range: the boxes' sizes (910 + 2 i) were measured on the frame and their
/// format register reads 0xFFFF.
inline constexpr std::uint16_t kResFormatsMeasured = 1u << 5;
// pick flags (register 541)
inline constexpr std::uint16_t kPickGripper = 1u << 0;  ///< a gripper is configured: pick data valid
// cell health flags (register 146)
inline constexpr std::uint16_t kHealthInvalid = 1u << 0;    ///< pixels without depth over the limit
inline constexpr std::uint16_t kHealthFlying = 1u << 1;     ///< mixed pixels over the limit
inline constexpr std::uint16_t kHealthSaturated = 1u << 2;  ///< saturated pixels over the limit
inline constexpr std::uint16_t kHealthNoise = 1u << 3;      ///< plane noise over the limit
inline constexpr std::uint16_t kHealthDrift = 1u << 4;      ///< drift over the limit
inline constexpr std::uint16_t kHealthDriftReference = 1u << 5;  ///< a drift reference is loaded
inline constexpr std::uint16_t kHealthDriftMeasured = 1u << 6;   ///< the last frame was compared with it
inline constexpr std::uint16_t kHealthWindowWarnings = kHealthInvalid | kHealthFlying | kHealthSaturated | kHealthNoise;
// layer info flags (register 131)
inline constexpr std::uint16_t kLayerHeightKnown = 1u << 0;
inline constexpr std::uint16_t kLayersRemainingKnown = 1u << 1;

/// Error codes in register 101 (the detail in 102 depends on the code).
enum class ErrorCode : std::uint16_t {
  kNone = 0,
  kFrameTimeout = 1,        ///< no frame captured after the trigger within the frame timeout
  kDetectionTimeout = 2,    ///< detection took longer than the detection timeout
  kDetectionFailed = 3,     ///< detail: DetectionFailure
  kCameraDisconnected = 4,  ///< detail: reconnect attempts so far (saturated at 65535)
  kUnknownRecipe = 5,       ///< detail: the recipe number asked for
  kPlcHeartbeatLost = 6,    ///< register 3 did not change within the configured timeout
  kInternal = 7,            ///< anything else; see the log
  kPickCheckFailed = 8,     ///< detail: PickCheckFailure; the result block keeps the last layout
};

/// Detail codes (register 102) for ErrorCode::kPickCheckFailed.
enum class PickCheckFailure : std::uint16_t {
  kNoLayout = 1,       ///< the result in the block has no boxes to check against
  kNothingPicked = 2,  ///< registers 4 and 5 name no box or group of that result
  kBadFrame = 3,       ///< the frame after the pick cannot be read against the last one
};

/// What a pick check found (register 135); 0 on the result of a detection.
enum class CheckResult : std::uint16_t {
  kNone = 0,
  kPickOk = 1,          ///< the picked boxes are gone, the others where they were
  kBoxStillThere = 2,   ///< a picked box still stands (missed pick): it stays in the result
  kExtraBoxGone = 3,    ///< a box that was not picked is gone too (double pick)
  kNeighbourMoved = 4,  ///< a box left moved beyond check.tolerance_mm: its slot holds the new pose
};

/// Detail codes (register 102) for ErrorCode::kDetectionFailed.
enum class DetectionFailure : std::uint16_t {
  kUnknown = 0,
  kNoPlane = 1,
  kNoLayer = 2,
  kNoLayout = 3,
  kBadFrame = 4,
  /// The boxes' measured sides disagree with the recipe's formats: register 532 names the
  /// configured recipe that fits best (numbered after ResultDetail's codes).
  kRecipeMismatch = 8,
};

/// Why a result has no boxes though nothing failed (register 130, and 102 while 101 = 0);
/// numbered after DetectionFailure's codes so that 102 has one meaning per value.
enum class ResultDetail : std::uint16_t {
  kNone = 0,
  kEmpty = 5,      ///< the empty pallet, or nothing stands inside the region of interest
  kSlipSheet = 6,  ///< a sheet covers the layer: remove it before the next trigger
  kLayerPicked = 7,  ///< a pick check found the layer's last box gone: trigger for the next level
};

/// Result status in register 202.
enum class ResultStatus : std::uint16_t { kOk = 0, kNoBoxes = 1, kFailed = 2 };

/// Pick status of a box slot (registers 870..901): pickable now, or what blocks it.
enum class PickStatus : std::uint16_t {
  kPickable = 0,
  kRoi = 1,          ///< the gripper would reach out of the region of interest or the view
  kHigherLevel = 2,  ///< something higher than the layer stands under the gripper
  kYawLimits = 3,    ///< neither of the box's yaws is within the robot's limits
  kNeighbour = 4,    ///< a neighbour has to go first
};

enum class WordOrder : std::uint8_t { kHighWordFirst, kLowWordFirst };

/// The whole addressable register space 0..902 (control, status, result extension, connection,
/// health, result and pick blocks; the gaps 16..99, 154..199, 533..539 and 545..549
/// read 0).
using RegisterImage = std::array<std::uint16_t, kRegisterCount>;

/// One box as the service computed it, in engineering units.
struct BoxRecord {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;  ///< box top centre [m] (base frame, else camera)
  double yaw_deg = 0.0;                    ///< long-axis angle about z [deg]; wrapped to -180..180
  std::uint16_t format = 0;                ///< index of the format in the recipe; 0xFFFF = measured
  double score = 0.0;                      ///< 0..1
  std::uint16_t pick_index = 0;            ///< position in the pick order, 1 = pick first
  PickStatus pick_status = PickStatus::kPickable;  ///< meaningful with ResultRecord::picking
  double long_m = 0.0, short_m = 0.0;      ///< top face [m] (910 + 2 i)
};

/// One pick of the gripper: a box, or boxes in consecutive slots taken together.
struct GroupRecord {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;  ///< TCP position [m] (base frame, else camera)
  double yaw_deg = 0.0;                    ///< TCP yaw about z [deg]; wrapped to -180..180
  std::uint16_t box_count = 0;             ///< boxes taken: slots first_box..first_box+box_count-1
  std::uint16_t first_box = 0;             ///< 0-based box slot (index into ResultRecord::boxes)
  std::uint16_t pick_index = 0;            ///< order of the picks, 1 = pick first
};

/// One finished detection as the service reports it. Box order is the service's; only the first
/// kMaxBoxes are encoded.
/// A pick check's findings (registers 135..139).
struct CheckRecord {
  CheckResult result = CheckResult::kNone;
  std::uint16_t boxes_gone = 0;
  std::uint16_t boxes_moved = 0;
  std::uint16_t moved_slot = 0;   ///< slot + 1 of the box that moved most; 0 = none moved
  double largest_move_m = 0.0;    ///< that box's move [m]
};

struct ResultRecord {
  std::uint16_t request_id = 0;  ///< request id latched with the trigger this answers
  std::uint16_t recipe = 0;      ///< recipe used
  ResultStatus status = ResultStatus::kOk;
  ErrorCode error = ErrorCode::kNone;  ///< for kFailed: why (goes to 101/102)
  std::uint16_t error_detail = 0;
  std::uint16_t boxes_found = 0;  ///< may exceed boxes.size() if the service truncated
  std::vector<BoxRecord> boxes;
  bool ambiguous = false;
  bool budget_exhausted = false;
  bool layer_clipped = false;
  bool outline_unobserved = false;  ///< the layer may go on where the depth ends
  bool height_off_layers = false;   ///< height above the pallet is no whole number of box heights
  bool formats_measured = false;    ///< size-range recipe: sizes measured, formats 0xFFFF (206 bit5)
  ResultDetail detail = ResultDetail::kNone;          ///< why no boxes (status kNoBoxes)
  std::optional<double> height_above_pallet_m;       ///< [m], when the pallet's height is configured
  std::optional<int> layers_remaining;                ///< counting the top layer
  double layer_z_m = 0.0;       ///< layer height [m]
  double coverage = 0.0;        ///< 0..1
  double layout_confidence = 0.0;  ///< 0..1, P(the layout is exact) (register 531)
  std::uint16_t best_recipe = 0;  ///< recipe mismatch: the configured recipe that fits best, 0 = none (532)
  double processing_ms = 0.0;   ///< detection wall time [ms] (register 113)
  bool picking = false;         ///< a gripper is configured: the pick fields below are valid
  std::uint16_t groups_found = 0;  ///< may exceed groups.size() if the service truncated
  /// The picks in pick order. Only groups whose boxes all lie in the reported box slots are
  /// encoded (at most kMaxGroups).
  std::vector<GroupRecord> groups;
  std::uint16_t pickable_boxes = 0;  ///< among all boxes found, not only the reported ones
  /// The result answers a PickCheck (registers 135..139); null for a detection's result.
  std::optional<CheckRecord> check;
};

/// Camera fault counters since the daemon started (registers 118..129), uint32 each.
struct CameraFaultCounters {
  std::uint32_t incomplete_frames = 0;  ///< frames refused: missing packets, wrong size or format
  std::uint32_t grab_timeouts = 0;      ///< grabs that ended without a frame in time
  std::uint32_t dropped_frames = 0;     ///< frames the camera sent that were lost (no buffer, overrun)
  std::uint32_t camera_losses = 0;      ///< times the camera was found gone (faulted)
  std::uint32_t camera_restarts = 0;    ///< stalled trigger-mode camera restarted by the daemon
  std::uint32_t resent_packets = 0;     ///< GigE Vision packets the camera resent on request

  friend bool operator==(const CameraFaultCounters& a, const CameraFaultCounters& b) {
    return a.incomplete_frames == b.incomplete_frames && a.grab_timeouts == b.grab_timeouts &&
           a.dropped_frames == b.dropped_frames && a.camera_losses == b.camera_losses &&
           a.camera_restarts == b.camera_restarts && a.resent_packets == b.resent_packets;
  }
};

/// The Modbus server's connection counters since start (registers 140..145).
struct ConnectionCounters {
  std::uint32_t evicted = 0;          ///< closed for a newer connection at the cap
  std::uint32_t refused = 0;          ///< refused by the allow list
  std::uint16_t open = 0;             ///< open now
  std::uint16_t max_connections = 0;  ///< the configured cap (`modbus.max_connections`)

  friend bool operator==(const ConnectionCounters& a, const ConnectionCounters& b) {
    return a.evicted == b.evicted && a.refused == b.refused && a.open == b.open &&
           a.max_connections == b.max_connections;
  }
  friend bool operator!=(const ConnectionCounters& a, const ConnectionCounters& b) { return !(a == b); }
};

/// The cell health block (registers 146..155) in engineering units.
struct HealthRecord {
  std::uint16_t flags = 0;        ///< kHealth* bits
  std::uint16_t frames = 0;       ///< frames in the window
  double invalid_fraction = 0.0;  ///< 0..1
  double flying_fraction = 0.0;   ///< 0..1
  double saturated_fraction = 0.0;  ///< 0..1
  double noise_ratio = 0.0;       ///< plane noise over the model's (0: not measured)
  double drift_shift_mm = 0.0;
  double drift_angle_deg = 0.0;

  friend bool operator==(const HealthRecord& a, const HealthRecord& b) {
    return a.flags == b.flags && a.frames == b.frames && a.invalid_fraction == b.invalid_fraction &&
           a.flying_fraction == b.flying_fraction && a.saturated_fraction == b.saturated_fraction &&
           a.noise_ratio == b.noise_ratio && a.drift_shift_mm == b.drift_shift_mm &&
           a.drift_angle_deg == b.drift_angle_deg;
  }
};

/// The status block's content in engineering units (what registers 100..129 and 140..155 show).
struct StatusRecord {
  std::uint16_t status_word = 0;  ///< kSt* bits
  ErrorCode error = ErrorCode::kNone;
  std::uint16_t error_detail = 0;
  std::uint16_t heartbeat = 0;
  std::uint16_t active_recipe = 0;
  std::uint16_t acquisition_id = 0;
  std::uint16_t result_id = 0;
  std::uint16_t last_request_id = 0;
  bool poses_in_camera_frame = false;
  std::uint16_t missed_triggers = 0;
  double processing_ms = 0.0;
  double latency_ms = 0.0;
  std::uint32_t frames_grabbed = 0;
  std::uint16_t camera_reconnects = 0;
  CameraFaultCounters camera_faults;  ///< 118..129
  ConnectionCounters connections;     ///< 140..145
  HealthRecord health;                ///< 146..155
};

/// The PLC's control block decoded.
struct ControlRecord {
  std::uint16_t control_word = 0;
  std::uint16_t recipe = 0;
  std::uint16_t request_id = 0;
  std::uint16_t plc_heartbeat = 0;
};

// ---- scalar conversions (saturating; non-finite values encode as 0) ----
std::int32_t metres_to_tenth_mm(double metres);
double tenth_mm_to_metres(std::int32_t value);
std::int16_t degrees_to_hundredths(double degrees);  ///< wraps to -180..180 first
double hundredths_to_degrees(std::int16_t value);
std::uint16_t unit_to_permille(double value);  ///< 0..1 -> 0..1000
std::uint16_t milliseconds_to_register(double ms);  ///< rounded, saturated at 65535

// ---- 32-bit values over two registers ----
void put_u32(std::uint16_t* dst, std::uint32_t value, WordOrder order);
std::uint32_t get_u32(const std::uint16_t* src, WordOrder order);
void put_i32(std::uint16_t* dst, std::int32_t value, WordOrder order);
std::int32_t get_i32(const std::uint16_t* src, WordOrder order);

// ---- blocks ----
/// Writes registers 100..129 and 140..155.
void encode_status(const StatusRecord& status, WordOrder order, RegisterImage& image);
/// Writes registers 200..532 with `result_id` in 200 and 530 (unused box slots zeroed), the
/// result extension 130..139 and the pick block 540..902 (`result_id` in 540 and 902; the rest
/// zero without `picking` and for a failed result).
void encode_result(const ResultRecord& result, std::uint16_t result_id, WordOrder order,
                   RegisterImage& image);
/// Clears registers 200..974 and 130..139 (no result yet).
void clear_result(RegisterImage& image);

ControlRecord decode_control(const RegisterImage& image);

/// The result and pick blocks read back (what a PLC sees), values converted to engineering units.
struct DecodedResult {
  std::uint16_t result_id = 0;
  std::uint16_t result_id_copy = 0;  ///< register 530; differs from result_id on a torn read
  std::uint16_t pick_result_id = 0;       ///< register 540
  std::uint16_t pick_result_id_copy = 0;  ///< register 902
  std::uint16_t size_result_id_copy = 0;  ///< register 974
  ResultRecord record;               ///< error/error_detail/processing_ms are not in this block

  /// The result id is the same in 200, 530, 540, 902 and 974: the reads belong to one result.
  [[nodiscard]] bool ids_agree() const {
    return result_id_copy == result_id && pick_result_id == result_id && pick_result_id_copy == result_id &&
           size_result_id_copy == result_id;
  }
};
DecodedResult decode_result(const RegisterImage& image, WordOrder order);
StatusRecord decode_status(const RegisterImage& image, WordOrder order);

}  // namespace palletd::modbus
