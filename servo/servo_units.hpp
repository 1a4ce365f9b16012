#pragma once
// Conversions between the virtual arm's SI values and the PIC-SERVO SC's units for one joint
// (docs/servo-units.md). The encoder sits on the motor, so one joint radian (or metre) is
// encoder_counts_per_rev * gear_ratio / (2 pi) counts (gear_ratio counts motor turns per joint
// turn, or per metre for a prismatic joint); a negative gear ratio turns the motor, and so the
// counts, the other way. A PWM of +255 applies the motor's full torque in the motor's positive
// sense, which is gear_ratio * motor_torque_max_nm at the joint.

#include <cstdint>

#include "core/robot_model.hpp"
#include "servo/picservo.hpp"

namespace sirupp::servo {

class JointDrive {
 public:
  // From the joint's servo parameters and the servo tick (s). Throws std::invalid_argument if the
  // drive cannot be converted (zero gear ratio or counts, non-positive tick).
  JointDrive(const core::Joint& joint, double tick_s);

  double counts_per_unit() const { return counts_per_unit_; }  // signed: counts per rad (or m)
  double tick_s() const { return tick_s_; }

  // Joint position (rad or m) to whole encoder counts, rounded to nearest, and back.
  int64_t ToCounts(double position) const;
  double FromCounts(int64_t counts) const;
  // Speed (rad/s or m/s, magnitude) to LOAD_TRAJ's velocity word: counts per tick << 16, >= 1.
  int64_t VelocityWord(double speed) const;
  double SpeedFromWord(int64_t word) const;
  // Acceleration (rad/s^2 or m/s^2, magnitude) to LOAD_TRAJ's acceleration word, >= 1.
  int64_t AccelerationWord(double acceleration) const;
  double AccelerationFromWord(int64_t word) const;
  // Joint effort (N*m or N) of a PWM value (-255..255).
  double EffortFromPwm(int pwm) const;

 private:
  double counts_per_unit_;
  double tick_s_;
  double effort_per_pwm_;
};

// ServoGains from a joint's servo parameters in the model (rounded to the chip's integers).
ServoGains GainsFromModel(const core::ServoParams& servo);

}  // namespace sirupp::servo
