#include "control/control_node.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <stdexcept>
#include <utility>

#include "core/errors.hpp"
#include "core/translate.hpp"

namespace sirupp::control {
namespace {

using Clock = std::chrono::steady_clock;

constexpr double kStatusPeriodS = 0.1;  // CONTROLLER_STATUS at 10 Hz (and on every change)

}  // namespace

ControlNode::ControlNode(core::Bus& bus, const core::RobotModel& model, ControlOptions options)
    : bus_(bus),
      model_(model),
      options_(std::move(options)),
      bank_(model),
      heartbeat_(bus, options_.name, options_.channels.heartbeat) {
  bus_.Subscribe<sirupp::arm_state_t>(
      options_.channels.sim_arm_state,
      [this](const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
        OnState(message, info);
      },
      1000);
  bus_.Subscribe<sirupp::joint_target_t>(
      options_.channels.arm_target,
      [this](const sirupp::joint_target_t& message, const core::ReceiveInfo& info) {
        OnTarget(message, info);
      });
  heartbeat_.Publish(core::ProcessState::kStarting, "");
}

void ControlNode::OnState(const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
  const core::ArmState state =
      core::ArmStateFromMessage(message, info.channel, model_.num_joints());
  if (state.tick <= last_tick_) return;  // the same tick sent again: already answered
  last_tick_ = state.tick;
  last_state_utime_ = state.utime;
  if (!servos_on_) {
    bank_.ServoOn(state.position);
    servos_on_ = true;
    if (!pending_.empty()) bank_.Load(pending_);
    pending_.clear();
  }
  core::ArmCommand command;
  command.utime = state.utime;
  command.tick = state.tick;
  command.sender = options_.name;
  command.mode = core::CommandMode::kEffort;
  command.effort = bank_.Tick(state.position);
  if (options_.effort_law && !StudentEfforts(state, command.effort)) {
    command.mode = core::CommandMode::kHold;
    command.effort.assign(command.effort.size(), 0.0);
  }
  bus_.Publish(options_.channels.sim_arm_command, core::ToMessage(command, command_seq_++));
  ++states_answered_;
  if (options_.publish_setpoints) {
    sirupp::servo_setpoint_t setpoint{};
    setpoint.utime = state.utime;
    setpoint.seq = setpoint_seq_++;
    setpoint.tick = state.tick;
    setpoint.move_id = move_id_;
    setpoint.num_joints = model_.num_joints();
    for (int j = 0; j < model_.num_joints(); ++j) {
      const PicServo& servo = bank_.servo(j);
      const JointDrive& drive = bank_.drive(j);
      setpoint.position.push_back(bank_.SetpointPosition(j));
      setpoint.velocity.push_back(bank_.SetpointVelocity(j));
      setpoint.goal.push_back(static_cast<double>(servo.profile().goal()) / 65536.0 /
                              drive.counts_per_unit());
      setpoint.position_error.push_back(static_cast<double>(servo.position_error()) /
                                        drive.counts_per_unit());
      setpoint.effort.push_back(command.effort[static_cast<size_t>(j)]);
      setpoint.status.push_back(static_cast<int8_t>(servo.status()));
    }
    bus_.Publish(options_.channels.arm_setpoint, setpoint);
  }
}

void ControlNode::OnTarget(const sirupp::joint_target_t& message, const core::ReceiveInfo& info) {
  const int n = model_.num_joints();
  std::vector<JointMove> moves(static_cast<size_t>(n));
  try {
    if (message.num_joints != n) {
      throw core::MessageError(
          info.channel, "num_joints",
          std::to_string(message.num_joints) + " joints; the model has " + std::to_string(n));
    }
    for (int j = 0; j < n; ++j) {
      const auto i = static_cast<size_t>(j);
      if (message.active[i] == 0) continue;
      const core::Joint& joint = model_.joints[i];
      const std::string at = "[" + std::to_string(j) + "]";
      const double goal = message.position[i];
      if (!std::isfinite(goal) || goal < joint.position_min || goal > joint.position_max) {
        throw core::MessageError(info.channel, "position" + at,
                                 core::FormatNumber(goal) + " is outside joint " +
                                     std::to_string(j + 1) + "'s limits [" +
                                     core::FormatNumber(joint.position_min) + ", " +
                                     core::FormatNumber(joint.position_max) + "]");
      }
      const double speed = message.max_velocity[i];
      const double acceleration = message.acceleration[i];
      if (!std::isfinite(speed) || speed < 0 || !std::isfinite(acceleration) || acceleration < 0) {
        throw core::MessageError(info.channel, "max_velocity/acceleration" + at,
                                 core::FormatNumber(speed) + ", " +
                                     core::FormatNumber(acceleration) +
                                     ": allowed finite values >= 0 (0 = the joint's default)");
      }
      moves[i] = {true, goal,
                  speed > 0 ? std::min(speed, joint.velocity_max) : joint.servo.default_velocity,
                  acceleration > 0 ? acceleration : joint.servo.default_acceleration};
    }
    if (servos_on_) {
      bank_.Load(moves);
    } else {
      pending_ = moves;  // loaded when the first arm state switches the servos on
    }
  } catch (const core::MessageError& error) {
    last_error_ = error.what();
    PublishStatus(true);
    throw;  // counted as rejected on ARM_TARGET
  }
  ++move_id_;
  sirupp::servo_move_t move{};
  move.utime = last_state_utime_;
  move.seq = move_seq_++;
  move.move_id = move_id_;
  move.command = sirupp::servo_move_t::COMMAND_MOVE;
  move.num_joints = n;
  for (const JointMove& joint_move : moves) {
    move.goal.push_back(joint_move.goal);
    move.max_velocity.push_back(joint_move.velocity);
    move.acceleration.push_back(joint_move.acceleration);
    move.flags.push_back(joint_move.active ? sirupp::servo_move_t::FLAG_ACTIVE : 0);
  }
  bus_.Publish(options_.channels.arm_move, move);
  PublishStatus(true);
}

bool ControlNode::StudentEfforts(const core::ArmState& state, std::vector<double>& effort) {
  if (law_failed_) return false;
  const int n = model_.num_joints();
  ControlInput& input = law_input_;
  input.time_s = static_cast<double>(state.utime) * 1e-6;
  input.tick = state.tick;
  input.state = &state;
  input.setpoint_position.resize(static_cast<size_t>(n));
  input.setpoint_velocity.resize(static_cast<size_t>(n));
  input.setpoint_acceleration.resize(static_cast<size_t>(n));
  input.goal.resize(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    input.setpoint_position[i] = bank_.SetpointPosition(j);
    input.setpoint_velocity[i] = bank_.SetpointVelocity(j);
    input.setpoint_acceleration[i] = bank_.SetpointAcceleration(j);
    input.goal[i] = bank_.Goal(j);
  }
  const std::string& name = options_.effort_law->name();
  try {
    if (!law_reset_) {
      options_.effort_law->Reset(input);
      law_reset_ = true;
    }
    effort.assign(static_cast<size_t>(n), 0.0);
    options_.effort_law->Update(input, effort);
    if (effort.size() != static_cast<size_t>(n)) {
      throw std::runtime_error("returned " + std::to_string(effort.size()) + " efforts for " +
                               std::to_string(n) + " joints");
    }
    for (int j = 0; j < n; ++j) {
      const double value = effort[static_cast<size_t>(j)];
      if (!std::isfinite(value)) {
        throw std::runtime_error("returned effort " + core::FormatNumber(value) + " for joint " +
                                 std::to_string(j + 1) + " (allowed: finite values)");
      }
      const double limit = model_.joints[static_cast<size_t>(j)].effort_max;
      effort[static_cast<size_t>(j)] = std::clamp(value, -limit, limit);
    }
  } catch (const std::exception& error) {
    law_failed_ = true;
    last_error_ = "controller '" + name + "' at tick " + std::to_string(state.tick) + ": " +
                  error.what() + "; the arm is held";
    std::cerr << "sirupp-control: " << last_error_ << "\n";
    PublishStatus(true);
    return false;
  }
  return true;
}

int8_t ControlNode::State() const {
  if (!servos_on_) return sirupp::controller_status_t::STATE_OFF;
  if (law_failed_) return sirupp::controller_status_t::STATE_FAULT;
  for (int j = 0; j < bank_.num_joints(); ++j) {
    if (bank_.servo(j).status() & kPositionError) return sirupp::controller_status_t::STATE_FAULT;
  }
  return bank_.AllDone() ? sirupp::controller_status_t::STATE_IDLE
                         : sirupp::controller_status_t::STATE_MOVING;
}

void ControlNode::PublishStatus(bool force) {
  const int8_t state = State();
  const Clock::time_point now = Clock::now();
  if (!force && state == last_reported_state_ &&
      std::chrono::duration<double>(now - last_status_).count() < kStatusPeriodS) {
    return;
  }
  sirupp::controller_status_t status{};
  status.utime = last_state_utime_;
  status.seq = status_seq_++;
  status.mode = sirupp::controller_status_t::MODE_MANUAL;
  status.state = state;
  status.move_id = move_id_;
  status.last_error = last_error_;
  bus_.Publish(options_.channels.controller_status, status);
  last_reported_state_ = state;
  last_status_ = now;
}

void ControlNode::Service(int max_wait_ms) {
  bus_.HandleAvailable();
  bus_.Handle(max_wait_ms);
  PublishStatus(false);
  const bool fault = State() == sirupp::controller_status_t::STATE_FAULT;
  heartbeat_.PublishIfDue(fault ? core::ProcessState::kFault : core::ProcessState::kRunning,
                          fault ? "a servo tripped its position-error limit" : last_error_);
}

}  // namespace sirupp::control
