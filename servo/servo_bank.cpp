#include "servo/servo_bank.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "core/errors.hpp"

namespace sirupp::servo {

ServoBank::ServoBank(const core::RobotModel& model) {
  for (const core::Joint& joint : model.joints) {
    drives_.emplace_back(joint, model.servo_tick_s);
    servos_.emplace_back();
    servos_.back().SetGains(GainsFromModel(joint.servo));
  }
  efforts_.assign(servos_.size(), 0.0);
  previous_velocity_.assign(servos_.size(), 0);
}

void ServoBank::ServoOn(const std::vector<double>& positions) {
  for (size_t j = 0; j < servos_.size(); ++j) servos_[j].ServoOn(drives_[j].ToCounts(positions[j]));
}

bool ServoBank::Load(const std::vector<JointMove>& moves) {
  if (moves.size() != servos_.size()) {
    throw std::invalid_argument("move has " + std::to_string(moves.size()) +
                                " joints; the arm has " + std::to_string(servos_.size()));
  }
  for (size_t j = 0; j < moves.size(); ++j) {
    const JointMove& move = moves[j];
    if (!move.active) continue;
    if (!std::isfinite(move.goal) || !(move.velocity > 0) || !(move.acceleration > 0) ||
        !std::isfinite(move.velocity) || !std::isfinite(move.acceleration)) {
      throw std::invalid_argument("joint " + std::to_string(j + 1) + ": goal " +
                                  core::FormatNumber(move.goal) + ", velocity " +
                                  core::FormatNumber(move.velocity) + ", acceleration " +
                                  core::FormatNumber(move.acceleration) +
                                  ": goal must be finite, velocity and acceleration > 0");
    }
  }
  bool all_on = true;
  for (size_t j = 0; j < moves.size(); ++j) {
    const JointMove& move = moves[j];
    if (!move.active) continue;
    all_on = servos_[j].LoadTrajectory(drives_[j].ToCounts(move.goal),
                                       drives_[j].VelocityWord(move.velocity),
                                       drives_[j].AccelerationWord(move.acceleration)) &&
             all_on;
  }
  return all_on;
}

void ServoBank::StopSmooth() {
  for (PicServo& servo : servos_) servo.StopSmooth();
}

void ServoBank::MotorOff() {
  for (PicServo& servo : servos_) servo.MotorOff();
}

void ServoBank::SetGains(int joint, const ServoGains& gains) {
  servos_.at(static_cast<size_t>(joint)).SetGains(gains);
}

void ServoBank::ReplaceModel(const core::RobotModel& model, const std::vector<double>& positions,
                             bool on) {
  if (model.num_joints() != num_joints() ||
      (on && positions.size() != static_cast<size_t>(num_joints()))) {
    throw std::invalid_argument("the new model has " + std::to_string(model.num_joints()) +
                                " joints; the servos drive " + std::to_string(num_joints()));
  }
  for (size_t j = 0; j < servos_.size(); ++j) {
    JointDrive drive(model.joints[j], model.servo_tick_s);
    if (drive.counts_per_unit() != drives_[j].counts_per_unit()) {
      servos_[j] = PicServo();
      servos_[j].SetGains(GainsFromModel(model.joints[j].servo));
      if (on) servos_[j].ServoOn(drive.ToCounts(positions[j]));
      previous_velocity_[j] = 0;
    }
    drives_[j] = drive;
  }
}

const std::vector<double>& ServoBank::Tick(const std::vector<double>& positions) {
  for (size_t j = 0; j < servos_.size(); ++j) {
    previous_velocity_[j] = servos_[j].profile().velocity();
    const int pwm = servos_[j].Tick(drives_[j].ToCounts(positions[j]));
    efforts_[j] = drives_[j].EffortFromPwm(pwm);
  }
  return efforts_;
}

bool ServoBank::AllDone() const {
  for (const PicServo& servo : servos_) {
    if (!(servo.status() & servo::kMoveDone)) return false;
  }
  return true;
}

double ServoBank::SetpointPosition(int joint) const {
  const auto j = static_cast<size_t>(joint);
  return static_cast<double>(servos_[j].profile().position()) / 65536.0 /
         drives_[j].counts_per_unit();
}

double ServoBank::SetpointVelocity(int joint) const {
  const auto j = static_cast<size_t>(joint);
  return static_cast<double>(servos_[j].profile().velocity()) / 65536.0 /
         drives_[j].counts_per_unit() / drives_[j].tick_s();
}

double ServoBank::SetpointAcceleration(int joint) const {
  const auto j = static_cast<size_t>(joint);
  const double tick_s = drives_[j].tick_s();
  return static_cast<double>(servos_[j].profile().velocity() - previous_velocity_[j]) / 65536.0 /
         drives_[j].counts_per_unit() / (tick_s * tick_s);
}

double ServoBank::Goal(int joint) const {
  const auto j = static_cast<size_t>(joint);
  return static_cast<double>(servos_[j].profile().goal()) / 65536.0 / drives_[j].counts_per_unit();
}

double ServoBank::PositionError(int joint) const {
  const auto j = static_cast<size_t>(joint);
  return static_cast<double>(servos_[j].position_error()) / drives_[j].counts_per_unit();
}

uint8_t ServoBank::Status(int joint) const { return servos_[static_cast<size_t>(joint)].status(); }

const ServoGains& ServoBank::Gains(int joint) const {
  return servos_[static_cast<size_t>(joint)].gains();
}

int ServoBank::TrippedJoint() const {
  for (int j = 0; j < num_joints(); ++j) {
    if (Status(j) & servo::kPositionError) return j;
  }
  return -1;
}

void ApplyMove(ServoBank& bank, const core::ServoMove& move, const std::vector<double>& positions) {
  const auto n = static_cast<size_t>(bank.num_joints());
  if (move.joints.size() != n) {
    throw std::invalid_argument("the command has " + std::to_string(move.joints.size()) +
                                " joints; the boards drive " + std::to_string(n));
  }
  if (positions.size() != n) {
    throw std::invalid_argument("the arm's state has " + std::to_string(positions.size()) +
                                " joints; the boards drive " + std::to_string(n));
  }
  switch (move.command) {
    case core::MoveCommand::kMove: {
      std::vector<JointMove> moves(n);
      for (size_t j = 0; j < n; ++j) {
        const core::JointMove& joint = move.joints[j];
        if ((joint.flags & kMoveFlagActive) == 0) continue;
        if ((joint.flags & ~kMoveFlagActive) != 0) {
          throw std::invalid_argument("joint " + std::to_string(j + 1) + ": flags " +
                                      std::to_string(joint.flags) +
                                      ": the virtual boards take FLAG_ACTIVE only (absolute "
                                      "position moves)");
        }
        moves[j] = {true, joint.goal, joint.max_velocity, joint.acceleration};
      }
      bank.Load(moves);  // throws naming the joint before it loads any
      return;
    }
    case core::MoveCommand::kStopSmooth:
      bank.StopSmooth();
      return;
    case core::MoveCommand::kStopAbrupt:
    case core::MoveCommand::kServoOn:
      bank.ServoOn(positions);
      return;
    case core::MoveCommand::kMotorOff:
      bank.MotorOff();
      return;
  }
  throw std::invalid_argument("command " + std::to_string(static_cast<int>(move.command)) +
                              ": allowed COMMAND_MOVE, STOP_SMOOTH, STOP_ABRUPT, MOTOR_OFF, "
                              "SERVO_ON");
}

}  // namespace sirupp::servo
