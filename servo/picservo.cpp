#include "servo/picservo.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace sirupp::servo {
namespace {

int64_t Sign(int64_t value) { return (value > 0) - (value < 0); }

int64_t Abs(int64_t value) { return value < 0 ? -value : value; }

// The speed (fixed point) from which `distance` is covered exactly by braking `a` per tick.
int64_t StoppableSpeed(int64_t distance, int64_t a) {
  const double d = static_cast<double>(distance);
  const double af = static_cast<double>(a);
  // Smallest n with a (n + 1) (n + 2) / 2 >= d.
  auto reach = [af](double n) { return af * (n + 1) * (n + 2) / 2; };
  double n = std::max(0.0, std::ceil((-3 + std::sqrt(1 + 8 * d / af)) / 2));
  while (n > 0 && reach(n - 1) >= d) n -= 1;
  while (reach(n) < d) n += 1;
  return static_cast<int64_t>(std::floor((d + af * n * (n + 1) / 2) / (n + 1)));
}

void CheckRange(const char* field, int value, int low, int high) {
  if (value < low || value > high) {
    throw std::invalid_argument(std::string(field) + " " + std::to_string(value) + ": allowed " +
                                std::to_string(low) + ".." + std::to_string(high));
  }
}

}  // namespace

void CheckGains(const ServoGains& gains) {
  CheckRange("kp", gains.kp, 0, 32767);
  CheckRange("kd", gains.kd, 0, 32767);
  CheckRange("ki", gains.ki, 0, 32767);
  CheckRange("integration_limit", gains.integration_limit, 0, 32767);
  CheckRange("output_limit", gains.output_limit, 0, 255);
  CheckRange("error_limit", gains.error_limit, 0, 32767);
  CheckRange("deadband", gains.deadband, 0, 255);
}

TrapezoidalProfile::TrapezoidalProfile(int64_t position_fixed)
    : position_(position_fixed), goal_(position_fixed) {}

void TrapezoidalProfile::SetGoal(int64_t goal_fixed, int64_t velocity_fixed,
                                 int64_t acceleration_fixed) {
  if (velocity_fixed <= 0 || acceleration_fixed <= 0) {
    throw std::invalid_argument("profile velocity " + std::to_string(velocity_fixed) +
                                " and acceleration " + std::to_string(acceleration_fixed) +
                                ": both must be > 0");
  }
  goal_ = goal_fixed;
  max_velocity_ = velocity_fixed;
  acceleration_ = acceleration_fixed;
  stopping_ = false;
  velocity_mode_ = false;
  done_ = goal_ == position_ && velocity_ == 0;
}

void TrapezoidalProfile::SetVelocity(int64_t velocity_fixed, int64_t acceleration_fixed) {
  if (acceleration_fixed <= 0) {
    throw std::invalid_argument("profile acceleration " + std::to_string(acceleration_fixed) +
                                ": must be > 0");
  }
  target_velocity_ = velocity_fixed;
  acceleration_ = acceleration_fixed;
  stopping_ = false;
  velocity_mode_ = true;
  done_ = velocity_ == target_velocity_;
}

void TrapezoidalProfile::StopSmooth() {
  if (done_ && !velocity_mode_) return;
  stopping_ = true;
  done_ = false;
}

void TrapezoidalProfile::HoldAt(int64_t position_fixed) {
  position_ = position_fixed;
  goal_ = position_fixed;
  velocity_ = 0;
  done_ = true;
  stopping_ = false;
  velocity_mode_ = false;
  phase_ = 0;
}

int64_t TrapezoidalProfile::Tick() {
  if (done_ && !velocity_mode_) {
    phase_ = 0;
    return position_;
  }
  const int64_t a = acceleration_;
  const int64_t speed = Abs(velocity_);
  if (stopping_) {
    velocity_ -= Sign(velocity_) * std::min(a, speed);
    position_ += velocity_;
    phase_ = kDecelerating;
    if (velocity_ == 0) {
      goal_ = position_;
      done_ = true;
      stopping_ = false;
      velocity_mode_ = false;
    }
    return position_;
  }
  if (velocity_mode_) {
    const int64_t step = std::clamp(target_velocity_ - velocity_, -a, a);
    velocity_ += step;
    position_ += velocity_;
    goal_ = position_;
    const int64_t new_speed = Abs(velocity_);
    phase_ = new_speed > speed ? kAccelerating : new_speed < speed ? kDecelerating : kSlewing;
    if (new_speed == 0 && speed == 0) phase_ = 0;
    done_ = velocity_ == target_velocity_;
    return position_;
  }
  const int64_t distance = goal_ - position_;
  const int64_t direction = Sign(distance);
  if (velocity_ != 0 && direction != Sign(velocity_)) {
    // Moving away from the goal (a new goal behind us, or an overshoot): brake first.
    velocity_ -= Sign(velocity_) * std::min(a, speed);
    position_ += velocity_;
    phase_ = kDecelerating;
    return position_;
  }
  // Towards the goal: the fastest speed from which braking by `a` each tick still lands exactly.
  // Braking from v = r + n a (0 < r <= a) covers r + (r + a) + ... + (r + n a) = (n + 1) v -
  // a n (n + 1) / 2 in n + 1 ticks and then stops; inverted for the remaining distance, this speed
  // makes every later tick brake by exactly `a` and the last one land on the goal.
  const int64_t stoppable = StoppableSpeed(Abs(distance), a);
  int64_t target = std::min({speed + a, max_velocity_, stoppable});
  target = std::max(target, speed - a);  // cannot brake harder than `a`
  phase_ = target > speed ? kAccelerating : target == speed ? kSlewing : kDecelerating;
  if (Abs(distance) <= target && target <= a) {
    // Lands this tick: the goal exactly, at rest.
    position_ = goal_;
    velocity_ = 0;
    done_ = true;
    return position_;
  }
  velocity_ = direction * target;
  position_ += velocity_;
  return position_;
}

PicServo::PicServo() { CheckGains(gains_); }

void PicServo::SetGains(const ServoGains& gains) {
  CheckGains(gains);
  gains_ = gains;
}

void PicServo::ServoOn(int64_t actual_counts) {
  profile_.HoldAt(ToFixed(actual_counts));
  error_ = 0;
  previous_error_ = 0;
  integral_ = 0;
  output_ = 0;
  pwm_mode_ = false;
  status_ = kServoOn | kMoveDone;
}

bool PicServo::LoadTrajectory(int64_t goal_counts, int64_t velocity_fixed,
                              int64_t acceleration_fixed) {
  if (!servo_on()) return false;
  profile_.SetGoal(ToFixed(goal_counts), velocity_fixed, acceleration_fixed);
  if (!profile_.done()) status_ = static_cast<uint8_t>(status_ & ~kMoveDone);  // MOVE_DONE drops
  return true;
}

bool PicServo::LoadVelocity(int64_t velocity_fixed, int64_t acceleration_fixed) {
  if (!servo_on()) return false;
  profile_.SetVelocity(velocity_fixed, acceleration_fixed);
  if (!profile_.done()) status_ = static_cast<uint8_t>(status_ & ~kMoveDone);
  return true;
}

void PicServo::StopSmooth() {
  profile_.StopSmooth();
  if (servo_on() && !profile_.done()) status_ = static_cast<uint8_t>(status_ & ~kMoveDone);
}

void PicServo::StopAbrupt(int64_t actual_counts) {
  profile_.HoldAt(ToFixed(actual_counts));
  previous_error_ = 0;
  if (servo_on()) status_ = static_cast<uint8_t>(status_ | kMoveDone);
}

void PicServo::StopHere(int64_t position_counts, int64_t actual_counts) {
  if (!servo_on()) ServoOn(actual_counts);
  profile_.HoldAt(ToFixed(position_counts));
  status_ = static_cast<uint8_t>(status_ | kMoveDone);
}

void PicServo::MotorOff() {
  status_ = static_cast<uint8_t>((status_ & kPositionError) | kMoveDone);
  output_ = 0;
  pwm_ = 0;
  pwm_mode_ = false;
  position_error_latched_ = true;
}

void PicServo::SetPwm(int pwm) {
  status_ = static_cast<uint8_t>((status_ & kPositionError) | kMoveDone);
  pwm_ = std::clamp(pwm, -kMaxPwm, kMaxPwm);
  output_ = pwm_;
  pwm_mode_ = true;
  position_error_latched_ = true;
}

void PicServo::ResetPosition(int64_t counts) {
  profile_.HoldAt(ToFixed(counts));
  error_ = 0;
  previous_error_ = 0;
  if (servo_on()) status_ = static_cast<uint8_t>(status_ | kMoveDone);
}

void PicServo::TripPositionError() {
  status_ = kPositionError | kMoveDone;
  output_ = 0;
  pwm_ = 0;
  pwm_mode_ = false;
  position_error_latched_ = true;
}

void PicServo::ClearLatches() { position_error_latched_ = !servo_on(); }

PicServo::ChipFlags PicServo::chip_flags() const {
  ChipFlags flags;
  flags.servo_on = servo_on();
  flags.move_done = !flags.servo_on || (status_ & kMoveDone) != 0;
  flags.position_error = position_error_latched_ || !flags.servo_on;
  flags.accel_done = accel_done_;
  flags.slew_done = !flags.servo_on || profile_.phase() == kSlewing || profile_.phase() == 0;
  return flags;
}

int PicServo::Tick(int64_t actual_counts) {
  if (!servo_on()) {
    profile_.HoldAt(ToFixed(actual_counts));  // the command follows the arm while the servo is off
    error_ = 0;
    output_ = pwm_mode_ ? pwm_ : 0;
    position_error_latched_ = true;
    return output_;
  }
  const int64_t command = WholeCounts(profile_.Tick());
  if (profile_.phase() == kAccelerating) accel_done_ = true;
  if (profile_.phase() == kDecelerating) accel_done_ = false;
  error_ = command - actual_counts;
  if (Abs(error_) > gains_.error_limit) {
    TripPositionError();  // servo off, latched
    return 0;
  }
  const int64_t integral_limit = static_cast<int64_t>(gains_.integration_limit) * kIntegralScale;
  integral_ = std::clamp(integral_ + error_, -integral_limit, integral_limit);
  const int64_t u = gains_.kp * error_ + gains_.kd * (error_ - previous_error_) +
                    gains_.ki * integral_ / kIntegralScale;
  previous_error_ = error_;
  int64_t pwm = u / (int64_t{1} << kOutputShift);  // truncates towards zero: symmetric
  const bool saturated = Abs(pwm) > gains_.output_limit;
  if (pwm != 0) pwm += Sign(pwm) * gains_.deadband;
  pwm = std::clamp<int64_t>(pwm, -gains_.output_limit, gains_.output_limit);
  output_ = static_cast<int>(pwm);
  status_ = static_cast<uint8_t>(kServoOn | (profile_.done() ? kMoveDone : 0) | profile_.phase() |
                                 (saturated ? kSaturated : 0));
  return output_;
}

}  // namespace sirupp::servo
