#include "servo/servo_units.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::servo {
namespace {

constexpr double kTwoPi = 6.28318530717958647692;
constexpr double kFixedScale = 65536.0;  // 16.16 fixed point
constexpr double kFullPwm = 255.0;

}  // namespace

JointDrive::JointDrive(const core::Joint& joint, double tick_s) : tick_s_(tick_s) {
  const core::ServoParams& servo = joint.servo;
  if (!(servo.encoder_counts_per_rev > 0) || !(servo.gear_ratio != 0) ||
      !std::isfinite(servo.gear_ratio) || !(tick_s > 0)) {
    throw std::invalid_argument("joint " + joint.name + ": servo drive needs encoder counts > 0 (" +
                                core::FormatNumber(servo.encoder_counts_per_rev) +
                                "), a nonzero gear ratio (" + core::FormatNumber(servo.gear_ratio) +
                                ") and a tick > 0 (" + core::FormatNumber(tick_s) + " s)");
  }
  const double per_motor_turn = servo.encoder_counts_per_rev * servo.gear_ratio;
  counts_per_unit_ =
      joint.type == core::JointType::kRevolute ? per_motor_turn / kTwoPi : per_motor_turn;
  effort_per_pwm_ = servo.motor_torque_max_nm * servo.gear_ratio / kFullPwm;
}

int64_t JointDrive::ToCounts(double position) const {
  return static_cast<int64_t>(std::llround(position * counts_per_unit_));
}

double JointDrive::FromCounts(int64_t counts) const {
  return static_cast<double>(counts) / counts_per_unit_;
}

int64_t JointDrive::VelocityWord(double speed) const {
  const double word = std::abs(speed * counts_per_unit_) * tick_s_ * kFixedScale;
  return std::max<int64_t>(1, std::llround(word));
}

double JointDrive::SpeedFromWord(int64_t word) const {
  return static_cast<double>(word) / (kFixedScale * tick_s_ * std::abs(counts_per_unit_));
}

int64_t JointDrive::AccelerationWord(double acceleration) const {
  const double word = std::abs(acceleration * counts_per_unit_) * tick_s_ * tick_s_ * kFixedScale;
  return std::max<int64_t>(1, std::llround(word));
}

double JointDrive::AccelerationFromWord(int64_t word) const {
  return static_cast<double>(word) / (kFixedScale * tick_s_ * tick_s_ * std::abs(counts_per_unit_));
}

double JointDrive::EffortFromPwm(int pwm) const { return effort_per_pwm_ * pwm; }

ServoGains GainsFromModel(const core::ServoParams& servo) {
  ServoGains gains;
  gains.kp = static_cast<int>(std::lround(servo.kp));
  gains.kd = static_cast<int>(std::lround(servo.kd));
  gains.ki = static_cast<int>(std::lround(servo.ki));
  gains.integration_limit = static_cast<int>(std::lround(servo.integration_limit));
  gains.output_limit = static_cast<int>(std::lround(servo.output_limit));
  gains.error_limit = static_cast<int>(std::lround(servo.error_limit));
  gains.deadband = static_cast<int>(std::lround(servo.deadband));
  return gains;
}

}  // namespace sirupp::servo
