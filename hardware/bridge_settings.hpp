#pragma once
// Settings of sirupp-hardware: the serial line, the polling rate and every safety threshold, read
// from a YAML file (config/hardware/puma260.yaml; docs/hardware.md lists each setting with its
// default and why). Angles in the file are degrees; here they are SI like everywhere else.

#include <string>
#include <vector>

#include "core/motion_limits.hpp"
#include "core/robot_model.hpp"

namespace sirupp::hardware {

// How a joint's zero is found during calibration.
enum class HomingMethod {
  kNone,    // the joint is at the calibration pose's angle when calibrating
  kIndex,   // move slowly until the encoder index changes
  kLimit1,  // ... until limit switch 1 changes
  kLimit2,  // ... until limit switch 2 changes
};
const char* HomingMethodName(HomingMethod method);

struct JointHoming {
  HomingMethod method = HomingMethod::kNone;
  double speed = 0.05;    // rad/s; the sign gives the search direction
  double home_angle = 0;  // rad: the joint angle at which the switch or index fires
};

struct BridgeSettings {
  std::string port;           // serial device; empty: must come from --port
  int baud = 230400;          // after start-up (modules power up at 19200)
  double poll_rate_hz = 100;  // REAL_ARM_STATE rate; every module is polled each cycle
  int reply_margin_ms = 10;   // wait for a reply beyond its line time
  int retries = 2;            // further tries of a failed exchange before it is a fault
  int group_address = 0x80;   // group of all joints (module 1 leads), for START_MOVE
  bool emulated = false;      // REAL_ARM_STATE source = SOURCE_EMULATED

  // Safety.
  double start_guard_s = 2.0;      // bus commands refused this long after start-up
  double command_timeout_s = 0.5;  // linked: controller silent this long while moving -> stop
  // Soft-limit margin, speed and acceleration caps: moves outside them are refused whole
  // (core::CheckJointMove, the rule the controller can apply too). Default
  // core::DefaultMotionLimits(model); the file's soft_limit_margin_deg, velocity_cap_fraction and
  // acceleration_max_deg_s2 override it.
  core::MotionLimits motion_limits;
  bool acceleration_from_file = false;  // else the model's default (follows a model change)
  bool pass_motor_off = false;          // mirror MOTOR_OFF (arm goes limp) instead of holding

  // Calibration.
  std::string calibration_pose = "zero";  // named pose of the model the arm sits in
  std::vector<JointHoming> homing;        // per joint; default none
  double homing_timeout_s = 30;
};

// Defaults for `model` (every per-joint list sized to its joints).
BridgeSettings DefaultBridgeSettings(const core::RobotModel& model);
// Reads `file` over the defaults; throws core::ConfigError (file:line:col: key: problem).
BridgeSettings LoadBridgeSettings(const std::string& file, const core::RobotModel& model);
BridgeSettings ParseBridgeSettings(const std::string& text, const std::string& name,
                                   const core::RobotModel& model);

// `settings` for another model of the same joint count (the sim's, taken while not linked): the
// acceleration caps the model's defaults unless the file gave them. Throws std::runtime_error when
// the joint count differs or the calibration pose is not a named pose of `model`.
BridgeSettings SettingsForModel(const BridgeSettings& settings, const core::RobotModel& model);

// Soft limits of joint j: the model's limits moved inward by the margin (core::SoftMin/SoftMax).
double SoftMin(const core::RobotModel& model, const BridgeSettings& s, int j);
double SoftMax(const core::RobotModel& model, const BridgeSettings& s, int j);

}  // namespace sirupp::hardware
