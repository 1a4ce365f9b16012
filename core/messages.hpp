#pragma once
// Value structs for the messages that core/arm_state.hpp, core/robot_model.hpp and
// core/environment.hpp do not already describe: one struct per lcmtypes/*.lcm type, so that a
// process builds and reads plain C++ values and core/translate.hpp does the wire format. Arrays
// that the message sends side by side with one count (num_joints) are one vector of per-joint
// structs here, so a count can never disagree with an array. Units as in the .lcm files.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/arm_state.hpp"
#include "core/bus.hpp"
#include "core/geometry.hpp"
#include "core/heartbeat.hpp"

namespace sirupp::core {

// ---- servo_setpoint_t (ARM_SETPOINT from sirupp-control, REAL_ARM_SETPOINT from sirupp-hardware)

// One joint's servo set-point. `status` holds servo_setpoint_t::STATUS_* bits. On
// REAL_ARM_SETPOINT the chips do not report a profile velocity and velocity is 0; position is the
// chip's command position (encoder position + position error) there, the profiled set-point on
// ARM_SETPOINT.
struct JointSetpoint {
  double position = 0;
  double velocity = 0;
  double goal = 0;
  double position_error = 0;  // set-point minus measured position
  double effort = 0;
  int8_t status = 0;
};

struct ServoSetpoint {
  int64_t utime = 0;
  int64_t seq = 0;
  int64_t tick = 0;
  int64_t move_id = 0;
  std::vector<JointSetpoint> joints;
};

// ---- board_status_t (SIM_BOARD_STATUS): the sim's virtual boards at an exchange tick

struct BoardStatus {
  int64_t utime = 0;
  int64_t seq = 0;
  int64_t tick = 0;
  int64_t next_tick = 0;
  int64_t command_seq = -1;
  ArmState arm;          // arm.tick == tick
  ServoSetpoint boards;  // the boards after their last tick; one joint per arm joint
};

// ---- arm_ticks_t (SIM_ARM_TICKS): several ticks of SIM_ARM_STATE and ARM_SETPOINT at once

struct TickedState {
  ArmState state;
  int64_t seq = 0;         // its SIM_ARM_STATE seq
  int64_t made_utime = 0;  // wall clock when it was made, us since the epoch
};
struct TickedSetpoint {
  ServoSetpoint setpoint;
  int64_t made_utime = 0;
};
struct ArmTicks {
  int64_t sent_utime = 0;
  int64_t seq = 0;
  std::vector<TickedState> states;  // in tick order
  std::vector<TickedSetpoint> setpoints;
};

// ---- servo_move_t (ARM_MOVE)

enum class MoveCommand : int8_t {
  kMove = 0,
  kStopSmooth = 1,
  kStopAbrupt = 2,
  kMotorOff = 3,
  kServoOn = 4
};

struct JointMove {
  double goal = 0;
  double max_velocity = 0;  // >= 0
  double acceleration = 0;  // >= 0
  int8_t flags = 0;         // servo_move_t::FLAG_* bits
};

struct ServoMove {
  int64_t utime = 0;
  int64_t seq = 0;
  int64_t move_id = 0;
  MoveCommand command = MoveCommand::kMove;
  std::vector<JointMove> joints;
};

// ---- servo_gains_t (ARM_GAINS, CONTROLLER_GAINS, REAL_ARM_GAINS)

// The nine SET_GAIN values of one joint as sent (doubles on the wire). Whether they are whole
// numbers in the chip's ranges for a given model is servo::ChipGainsFromMessage's rule.
struct JointGains {
  double kp = 0;
  double kd = 0;
  double ki = 0;
  double integration_limit = 0;
  double output_limit = 0;
  double current_limit = 0;
  double error_limit = 0;
  double servo_rate_divisor = 1;
  double deadband = 0;
};

struct ServoGainsSet {
  int64_t utime = 0;
  int64_t seq = 0;
  std::vector<JointGains> joints;
};

// ---- joint_target_t (ARM_TARGET)

struct JointGoal {
  double position = 0;
  double max_velocity = 0;  // >= 0; 0 = the model's default
  double acceleration = 0;  // >= 0; 0 = the model's default
  bool active = false;
};

struct JointTarget {
  int64_t utime = 0;
  int64_t seq = 0;
  std::vector<JointGoal> joints;
};

// ---- pose_target_t (ARM_POSE_TARGET)

enum class ArmChoice : int8_t { kAny = 0, kFirst = 1, kSecond = 2 };  // SHOULDER_/ELBOW_/WRIST_*

struct PoseTarget {
  int64_t utime = 0;
  int64_t seq = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // w, x, y, z on the wire
  bool position_only = false;
  ArmChoice shoulder = ArmChoice::kAny;  // kFirst = LEFT, kSecond = RIGHT
  ArmChoice elbow = ArmChoice::kAny;     // kFirst = UP, kSecond = DOWN
  ArmChoice wrist = ArmChoice::kAny;     // kFirst = NO_FLIP, kSecond = FLIP
  double speed_scale = 1;
};

// ---- plan_command_t (ARM_PLAN)

enum class PlanAction : int8_t {
  kRun = 0,
  kPause = 1,
  kResume = 2,
  kAbort = 3,
  kManual = 4,
  kAutomatic = 5,
  kClearFault = 6,
  kLoadModel = 7  // sirupp-control takes the model the sim is about to publish (model_switch.hpp)
};

struct PlanCommand {
  int64_t utime = 0;
  int64_t seq = 0;
  PlanAction command = PlanAction::kRun;
  std::string name;
  std::string text;
};

// ---- controller_status_t (CONTROLLER_STATUS)

enum class ControllerMode : int8_t { kManual = 0, kAutomatic = 1 };
enum class ControllerState : int8_t {
  kIdle = 0,
  kMoving = 1,
  kWaiting = 2,
  kPaused = 3,
  kFault = 4,
  kOff = 5
};

struct ControllerStatus {
  int64_t utime = 0;
  int64_t seq = 0;
  ControllerMode mode = ControllerMode::kManual;
  ControllerState state = ControllerState::kIdle;
  int64_t move_id = 0;
  std::string plan_name;
  int32_t plan_step = -1;  // -1: no plan
  int32_t plan_steps = 0;
  int32_t plan_line = 0;
  std::string last_error;
};

// ---- hardware_command_t (HARDWARE_COMMAND), hardware_status_t (HARDWARE_STATUS)

enum class HardwareAction : int8_t {
  kConnect = 0,
  kCalibrate = 1,
  kArm = 2,
  kDisarm = 3,
  kLink = 4,
  kUnlink = 5,
  kHome = 6,
  kClearFaults = 7
};

struct HardwareCommand {
  int64_t utime = 0;
  int64_t seq = 0;
  HardwareAction command = HardwareAction::kConnect;
  std::string sender;
};

enum class BridgeState : int8_t {
  kDisconnected = 0,
  kConnected = 1,
  kCalibrating = 2,
  kArmed = 3,
  kLinked = 4,
  kFault = 5,
  kEstopped = 6
};

struct ModuleReading {
  int16_t status = 0;      // the module's status byte
  int16_t aux_status = 0;  // its auxiliary status byte
  int32_t position_counts = 0;
  int32_t position_error_counts = 0;
};

struct HardwareStatus {
  int64_t utime = 0;
  int64_t seq = 0;
  BridgeState state = BridgeState::kDisconnected;
  bool calibrated = false;
  std::string port;
  int32_t baud = 0;
  std::vector<ModuleReading> modules;
  int64_t checksum_errors = 0;
  int64_t timeouts = 0;
  int64_t resyncs = 0;
  std::string last_error;
};

// ---- estop_t (ESTOP)

struct EStop {
  int64_t utime = 0;
  int64_t seq = 0;
  bool engaged = false;
  std::string sender;
  std::string reason;
};

// ---- sim_command_t (SIM_COMMAND)

enum class SimAction { kLoadEnvironment = 0, kLoadModel = 1 };

struct SimCommand {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string sender;
  SimAction action = SimAction::kLoadEnvironment;
  std::string name;  // where the text came from (a file name), for its errors
  std::string text;  // the environment's XML or the model's YAML, at most kMaxSimCommandText bytes
};
constexpr size_t kMaxSimCommandText = size_t{1} << 20;

// ---- logger_command_t (LOGGER_COMMAND)

enum class LoggerAction { kStart, kStop };

struct LoggerCommand {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string sender;
  LoggerAction action = LoggerAction::kStart;
  std::string name;  // the run to start (kStart)
};

// ---- logger_pass_t (LOGGER_PASS: in sirupp-logger's raw log only)

struct LoggerPass {
  int64_t utime = 0;          // the writer's wall clock at the pass
  int64_t seq = 0;            // pass counter
  int64_t taken = 0;          // messages taken by the writer so far, this pass's included
  bool last = false;          // the last pass: the files were closed after it
  int64_t started_utime = 0;  // the logger's start, wall clock
  std::string name;           // its run name
  std::string lcm_url;        // its bus
  // Its settings that shape the data files (--rate, --max-age, --idle, --split, --velocities,
  // --efforts, --note, --model, --prefix), for --from-log.
  int64_t period_us = 1;
  int64_t max_age_us = 0;
  int64_t idle_us = 1;
  bool split_per_plan = true;
  bool velocities = false;
  bool efforts = false;
  std::string note;
  std::string model_file;
  std::string prefix;
};

// ---- sim_reset_t (SIM_RESET)

struct SimReset {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string sender;
  std::vector<double> position;  // one per joint
  std::vector<double> velocity;  // empty (at rest) or one per joint
  bool reset_objects = false;
};

// ---- sim_status_t (SIM_STATUS)

enum class TimingMode : int8_t { kLockstep = 0, kRealtime = 1, kFast = 2, kFreerun = 3 };
enum class ParticipantState : int8_t { kAnswering = 0, kNeverSeen = 1, kSilent = 2 };

struct ParticipantReport {
  std::string name;
  ParticipantState state = ParticipantState::kNeverSeen;
  double answer_mean_ms = 0;
  double answer_max_ms = 0;
};

struct RefusalReport {
  std::string sender;
  int64_t count = 0;
  std::string reason;
};

struct SimStatus {
  int64_t utime = 0;
  int64_t seq = 0;
  int64_t run_id = 0;
  TimingMode mode = TimingMode::kLockstep;
  int64_t tick = 0;
  double sim_time_s = 0;
  double realtime_factor = 0;
  double realtime_factor_run = 0;
  double slipped_s = 0;
  bool estop = false;
  std::string estop_reason;
  std::vector<ParticipantReport> participants;
  std::vector<RefusalReport> refused;
  int64_t refused_others = 0;
  std::string detail;
};

// ---- viewer_camera_t (VIEWER_CAMERA)

enum class Switch : int8_t { kKeep = 0, kOn = 1, kOff = 2 };

struct ViewerCamera {
  int64_t utime = 0;
  int64_t seq = 0;
  bool set_camera = false;
  double azimuth = 0;    // rad, about world z from +x
  double elevation = 0;  // rad, above the x-y plane
  double distance = 0;   // m, > 0 when set_camera
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Switch show_frames = Switch::kKeep;
  Switch show_ghost = Switch::kKeep;
  bool snapshot = false;
};

// ---- heartbeat_t (HEARTBEAT) with channel_stats_t

struct ChannelTraffic {
  ChannelStats stats;  // last_error is not sent
  double rate_hz = 0;
};

struct HeartbeatReport {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string process;
  std::string host;
  int32_t pid = 0;
  ProcessState state = ProcessState::kStarting;
  std::string detail;
  double uptime_s = 0;
  std::vector<ChannelTraffic> channels;
};

// ---- command_reply_t (CONTROLLER_REPLY, HARDWARE_REPLY)

struct CommandReply {
  int64_t utime = 0;
  int64_t seq = 0;
  std::string sender;
  std::string request_channel;
  int64_t request_utime = 0;
  int64_t request_seq = 0;
  bool accepted = true;
  std::string error;  // empty when accepted, why otherwise
  int64_t move_id = -1;
  int64_t status_seq = -1;
};

// ---- image_t (VIEWER_IMAGE) with image_metadata_t

struct ImageMetadata {
  std::string key;
  std::vector<uint8_t> value;
};

// The image as sent; viewer/image_codec.hpp turns the pixels into an OpenCV image.
struct Image {
  int64_t utime = 0;
  int32_t width = 0;
  int32_t height = 0;
  int32_t row_stride = 0;
  int32_t pixelformat = 0;  // image_t::PIXEL_FORMAT_*
  std::vector<uint8_t> data;
  std::vector<ImageMetadata> metadata;
};

}  // namespace sirupp::core
