#pragma once
// One set of motion limits for everything that moves the arm: the rule sirupp-hardware applies
// before it sends a move to the real boards (refusing it whole), in one pure function that the
// controller and the plan checker can call too, so that a goal, speed or acceleration the real
// arm would refuse is refused before the virtual arm moves (issue 23; docs/hardware.md, "Motion
// limits").
//
// Per joint, a move is allowed when
//   - its speed is finite and in (0, velocity_max x velocity_cap_fraction] (velocity mode: the
//     signed speed nonzero, its magnitude within the cap),
//   - its acceleration is finite and in (0, acceleration_max[j]],
//   - (position mode) its goal is finite and inside the joint's limits moved inward by
//     soft_limit_margin: [position_min + margin, position_max - margin].
// Values are SI (rad, rad/s, rad/s^2; m for prismatic joints).

#include <optional>
#include <string>
#include <vector>

#include "core/robot_model.hpp"

namespace sirupp::core {

struct MotionLimits {
  double soft_limit_margin = 0;          // rad (or m) inside each joint's limits
  double velocity_cap_fraction = 1.0;    // of each joint's velocity_max
  std::vector<double> acceleration_max;  // per joint, rad/s^2 (or m/s^2)
};

// The defaults, from the model alone: margin 2 deg (the same number, 0.0349, in metres for a
// prismatic joint), speed cap velocity_max, acceleration cap 4 x each joint's
// default_acceleration. sirupp-hardware's settings file may override them
// (soft_limit_margin_deg, velocity_cap_fraction, acceleration_max_deg_s2); the shipped one does
// not change them.
MotionLimits DefaultMotionLimits(const RobotModel& model);
inline constexpr double kDefaultSoftLimitMarginDeg = 2;

// The soft limits of joint j: its limits moved inward by the margin.
double SoftMin(const RobotModel& model, const MotionLimits& limits, int joint);
double SoftMax(const RobotModel& model, const MotionLimits& limits, int joint);

// Why joint `joint` (0-based) may not move to `goal` at `speed` and `acceleration`, or nullopt
// when it may. In velocity mode `speed` is signed and `goal` is not looked at. The reason names
// the joint and the limit, in degrees for revolute joints, e.g.
//   "joint j2 (shoulder): goal 156 deg is outside the soft limits [-155.5 deg, 155.5 deg]"
//   "joint j1 (waist): acceleration 5.73e+13 deg/s^2 is outside (0, 1200 deg/s^2]
//    (acceleration cap)"
// Throws std::out_of_range for a joint index the model does not have.
std::optional<std::string> CheckJointMove(const RobotModel& model, const MotionLimits& limits,
                                          int joint, double goal, double speed, double acceleration,
                                          bool velocity_mode = false);

}  // namespace sirupp::core
