#include "control/boards.hpp"

#include <cmath>
#include <limits>
#include <sirupp/servo_move_t.hpp>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/errors.hpp"

namespace sirupp::control {
namespace {

constexpr double kNone = std::numeric_limits<double>::quiet_NaN();

}  // namespace

Boards::Boards(const core::RobotModel& model, bool remote) : bank_(model), remote_(remote) {
  const auto n = static_cast<size_t>(bank_.num_joints());
  pending_goal_.assign(n, kNone);
  status_.tick = -1;
  status_.joints.resize(n);
  for (size_t j = 0; j < n; ++j) {
    status_.joints[j].status = static_cast<int8_t>(bank_.Status(static_cast<int>(j)));
  }
}

void Boards::Send(core::MoveCommand command, const std::vector<double>& goals,
                  const std::vector<JointMove>* moves) {
  core::ServoMove move;
  move.seq = ++sent_seq_;
  move.move_id = move_id_;
  move.command = command;
  for (size_t j = 0; j < goals.size(); ++j) {
    core::JointMove joint;
    joint.goal = goals[j];
    joint.flags = sirupp::servo_move_t::FLAG_ACTIVE;
    if (moves != nullptr) {
      const JointMove& given = (*moves)[j];
      joint.max_velocity = given.velocity;
      joint.acceleration = given.acceleration;
      joint.flags = given.active ? sirupp::servo_move_t::FLAG_ACTIVE : 0;
    }
    move.joints.push_back(joint);
  }
  out_.push_back(std::move(move));
}

void Boards::ServoOn(const std::vector<double>& positions) {
  if (!remote_) {
    bank_.ServoOn(positions);
    return;
  }
  Send(core::MoveCommand::kServoOn, positions, nullptr);
  pending_servo_on_ = true;
  pending_motion_ = false;
  pending_goal_ = positions;
}

void Boards::Load(const std::vector<JointMove>& moves) {
  if (!remote_) {
    bank_.Load(moves);
    return;
  }
  // The checks ServoBank::Load makes, so a refusal comes here and not from the sim.
  ServoBank trial = bank_;
  trial.ServoOn(std::vector<double>(static_cast<size_t>(num_joints()), 0.0));
  trial.Load(moves);
  std::vector<double> goals(moves.size());
  for (size_t j = 0; j < moves.size(); ++j) {
    goals[j] = moves[j].active ? moves[j].goal : 0.0;
    if (moves[j].active) pending_goal_[j] = moves[j].goal;
  }
  Send(core::MoveCommand::kMove, goals, &moves);
  pending_motion_ = true;
}

void Boards::StopSmooth() {
  if (!remote_) {
    bank_.StopSmooth();
    return;
  }
  std::vector<double> goals(static_cast<size_t>(num_joints()));
  for (int j = 0; j < num_joints(); ++j) goals[static_cast<size_t>(j)] = SetpointPosition(j);
  Send(core::MoveCommand::kStopSmooth, goals, nullptr);
  pending_motion_ = true;
  pending_goal_.assign(pending_goal_.size(), kNone);
}

void Boards::SetGains(int joint, const ServoGains& gains) {
  // Remote: the bank keeps the gains in force; the sim's boards get them on CONTROLLER_GAINS.
  bank_.SetGains(joint, gains);
}

void Boards::ReplaceModel(const core::RobotModel& model, const std::vector<double>& positions,
                          bool on) {
  // Remote: the sim rebuilds its boards from the model it loads; the bank keeps the gains.
  bank_.ReplaceModel(model, positions, on && !remote_);
}

const std::vector<double>& Boards::Tick(const std::vector<double>& positions) {
  if (remote_) throw std::logic_error("Boards::Tick: the boards run in sirupp-sim");
  return bank_.Tick(positions);
}

std::vector<core::ServoMove> Boards::TakeCommands() {
  std::vector<core::ServoMove> taken;
  taken.swap(out_);
  return taken;
}

void Boards::TakeStatus(const core::ServoSetpoint& boards, int64_t command_seq) {
  if (boards.joints.size() != status_.joints.size()) {
    throw std::invalid_argument("the boards report " + std::to_string(boards.joints.size()) +
                                " joints; the arm has " + std::to_string(status_.joints.size()));
  }
  status_ = boards;
  applied_seq_ = command_seq;
  if (!Pending()) {
    pending_motion_ = false;
    pending_servo_on_ = false;
    pending_goal_.assign(pending_goal_.size(), kNone);
  }
}

const core::JointSetpoint& Boards::Reported(int joint) const {
  return status_.joints[static_cast<size_t>(joint)];
}

bool Boards::AllDone() const {
  if (!remote_) return bank_.AllDone();
  if (Pending() && pending_motion_) return false;
  for (int j = 0; j < num_joints(); ++j) {
    if (pending_servo_on_ && Pending()) continue;  // a servo-on holds at rest
    if (!(static_cast<uint8_t>(Reported(j).status) & servo::kMoveDone)) return false;
  }
  return true;
}

double Boards::SetpointPosition(int joint) const {
  return remote_ ? Reported(joint).position : bank_.SetpointPosition(joint);
}

double Boards::SetpointVelocity(int joint) const {
  return remote_ ? Reported(joint).velocity : bank_.SetpointVelocity(joint);
}

double Boards::SetpointAcceleration(int joint) const {
  return remote_ ? 0.0 : bank_.SetpointAcceleration(joint);
}

double Boards::Goal(int joint) const {
  if (!remote_) return bank_.Goal(joint);
  const double pending = pending_goal_[static_cast<size_t>(joint)];
  return std::isnan(pending) ? Reported(joint).goal : pending;
}

double Boards::PositionError(int joint) const {
  return remote_ ? Reported(joint).position_error : bank_.PositionError(joint);
}

uint8_t Boards::Status(int joint) const {
  return remote_ ? static_cast<uint8_t>(Reported(joint).status) : bank_.Status(joint);
}

int Boards::TrippedJoint() const {
  if (!remote_) return bank_.TrippedJoint();
  if (pending_servo_on_ && Pending()) return -1;
  for (int j = 0; j < num_joints(); ++j) {
    if (static_cast<uint8_t>(Reported(j).status) & servo::kPositionError) return j;
  }
  return -1;
}

}  // namespace sirupp::control
