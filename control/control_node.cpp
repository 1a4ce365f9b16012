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

#include "control/pose_goal.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/translate.hpp"

namespace sirupp::control {
namespace {

using Clock = std::chrono::steady_clock;
using Status = sirupp::controller_status_t;

constexpr double kStatusPeriodS = 0.1;  // CONTROLLER_STATUS at 10 Hz (and on every change)

std::string Index(int j) { return "[" + std::to_string(j) + "]"; }

// A gain carried as a double: a whole number in [low, high], else MessageError on `field[j]`.
int WholeGain(const std::string& channel, const char* field, int j, double value, int low,
              int high) {
  if (!std::isfinite(value) || value != std::floor(value) || value < low || value > high) {
    throw core::MessageError(channel, field + Index(j),
                             core::FormatNumber(value) + ": allowed whole numbers " +
                                 std::to_string(low) + ".." + std::to_string(high));
  }
  return static_cast<int>(value);
}

}  // namespace

ControlNode::ControlNode(core::Bus& bus, const core::RobotModel& model, ControlOptions options)
    : bus_(bus),
      model_(model),
      options_(std::move(options)),
      bank_(model),
      heartbeat_(bus, options_.name, options_.channels.heartbeat) {
  const core::Channels& channels = options_.channels;
  bus_.Subscribe<sirupp::arm_state_t>(
      channels.sim_arm_state,
      [this](const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
        OnState(message, info);
      },
      1000);
  bus_.Subscribe<sirupp::joint_target_t>(
      channels.arm_target, [this](const sirupp::joint_target_t& message,
                                  const core::ReceiveInfo& info) { OnTarget(message, info); });
  bus_.Subscribe<sirupp::pose_target_t>(
      channels.arm_pose_target,
      [this](const sirupp::pose_target_t& message, const core::ReceiveInfo& info) {
        OnPoseTarget(message, info);
      });
  bus_.Subscribe<sirupp::plan_command_t>(
      channels.arm_plan, [this](const sirupp::plan_command_t& message,
                                const core::ReceiveInfo& info) { OnPlan(message, info); });
  bus_.Subscribe<sirupp::servo_gains_t>(
      channels.arm_gains, [this](const sirupp::servo_gains_t& message,
                                 const core::ReceiveInfo& info) { OnGains(message, info); });
  bus_.Subscribe<sirupp::estop_t>(
      channels.estop, [this](const sirupp::estop_t& message, const core::ReceiveInfo& info) {
        OnEstop(message, info);
      });
  heartbeat_.Publish(core::ProcessState::kStarting, "");
}

void ControlNode::OnEstop(const sirupp::estop_t& message, const core::ReceiveInfo&) {
  if (!message.engaged) {
    if (estop_.empty()) return;
    estop_.clear();
    last_error_.clear();
    PublishStatus(true);
    return;
  }
  estop_ = "emergency stop from '" + message.sender + "': " + message.reason;
  if (servos_on_) bank_.ServoOn(positions_);  // command position = actual: held where it is
  pending_.clear();
  PublishStop(sirupp::servo_move_t::COMMAND_STOP_ABRUPT);
  if (plan_running_) {
    EndPlan(estop_ + "; plan " + plan_->name + " aborted");
  } else {
    last_error_ = estop_;
    PublishStatus(true);
  }
  std::cerr << "sirupp-control: " << estop_ << "\n";
}

void ControlNode::RequireNoEstop(const std::string& channel, const std::string& what) const {
  if (!estop_.empty()) {
    throw core::MessageError(
        channel, "",
        what + ": " + estop_ + " is engaged; release it first (sirupp estop --release)");
  }
}

void ControlNode::OnState(const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
  const core::ArmState state =
      core::ArmStateFromMessage(message, info.channel, model_.num_joints());
  if (state.tick <= last_tick_) return;  // the same tick sent again: already answered
  last_tick_ = state.tick;
  last_state_utime_ = state.utime;
  positions_ = state.position;
  if (!servos_on_) {
    bank_.ServoOn(state.position);
    servos_on_ = true;
    if (!pending_.empty()) bank_.Load(pending_);
    pending_.clear();
  }
  AdvancePlan(state.utime);

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

  const int tripped = TrippedJoint();
  if (tripped >= 0 && !trip_reported_) {
    trip_reported_ = true;
    const PicServo& servo = bank_.servo(tripped);
    bank_.StopSmooth();  // the other joints come to rest and hold
    const std::string error =
        "joint j" + std::to_string(tripped + 1) + " tripped its position-error limit (" +
        std::to_string(servo.gains().error_limit) + " counts) at tick " +
        std::to_string(state.tick) + ": its servo is off; the next target switches it on again";
    if (plan_running_) {
      EndPlan(error + "; plan " + plan_->name + " aborted");
    } else {
      last_error_ = error;
      PublishStatus(true);
    }
    std::cerr << "sirupp-control: " << last_error_ << "\n";
  }
  if (options_.publish_setpoints) PublishSetpoint(state, command.effort);
}

void ControlNode::PublishSetpoint(const core::ArmState& state, const std::vector<double>& effort) {
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
    setpoint.goal.push_back(bank_.Goal(j));
    setpoint.position_error.push_back(static_cast<double>(servo.position_error()) /
                                      drive.counts_per_unit());
    setpoint.effort.push_back(effort[static_cast<size_t>(j)]);
    setpoint.status.push_back(static_cast<int8_t>(servo.status()));
  }
  bus_.Publish(options_.channels.arm_setpoint, setpoint);
}

void ControlNode::CheckJointCount(const std::string& channel, int32_t num_joints) const {
  if (num_joints != model_.num_joints()) {
    throw core::MessageError(channel, "num_joints",
                             std::to_string(num_joints) + " joints; the model has " +
                                 std::to_string(model_.num_joints()));
  }
}

void ControlNode::Refuse(const core::MessageError& error) {
  last_error_ = error.what();
  PublishStatus(true);
}

void ControlNode::RequireManual(const std::string& channel) const {
  RequireNoEstop(channel, "target");
  if (plan_running_) {
    throw core::MessageError(channel, "",
                             "plan " + plan_->name + " is running (step " +
                                 std::to_string(plan_step_ + 1) + " of " +
                                 std::to_string(plan_->steps.size()) +
                                 "); targets are taken in manual mode only: abort "
                                 "the plan first (sirupp plan abort)");
  }
  if (locked_automatic_) {
    throw core::MessageError(channel, "",
                             "the controller is locked in automatic mode; targets are taken in "
                             "manual mode only (sirupp plan manual)");
  }
}

void ControlNode::StartMove(const std::vector<JointMove>& moves) {
  if (servos_on_) {
    if (TrippedJoint() >= 0) {
      bank_.ServoOn(positions_);  // clears the latched fault; every joint holds where it is
      trip_reported_ = false;
    }
    bank_.Load(moves);
  } else {
    pending_ = moves;  // loaded when the first arm state switches the servos on
  }
  ++move_id_;
  PublishMove(sirupp::servo_move_t::COMMAND_MOVE, moves);
}

void ControlNode::PublishStop(int8_t command) {
  std::vector<JointMove> stops;
  for (int j = 0; j < model_.num_joints(); ++j) {
    const core::Joint& joint = model_.joints[static_cast<size_t>(j)];
    stops.push_back({true, bank_.SetpointPosition(j), joint.servo.default_velocity,
                     joint.servo.default_acceleration});
  }
  PublishMove(command, stops);
}

void ControlNode::PublishMove(int8_t command, const std::vector<JointMove>& moves) {
  sirupp::servo_move_t move{};
  move.utime = last_state_utime_;
  move.seq = move_seq_++;
  move.move_id = move_id_;
  move.command = command;
  move.num_joints = model_.num_joints();
  for (const JointMove& joint_move : moves) {
    move.goal.push_back(joint_move.goal);
    move.max_velocity.push_back(joint_move.velocity);
    move.acceleration.push_back(joint_move.acceleration);
    move.flags.push_back(joint_move.active ? sirupp::servo_move_t::FLAG_ACTIVE : 0);
  }
  bus_.Publish(options_.channels.arm_move, move);
}

void ControlNode::OnTarget(const sirupp::joint_target_t& message, const core::ReceiveInfo& info) {
  const int n = model_.num_joints();
  std::vector<JointMove> moves(static_cast<size_t>(n));
  try {
    RequireManual(info.channel);
    CheckJointCount(info.channel, message.num_joints);
    bool any = false;
    for (int j = 0; j < n; ++j) {
      const auto i = static_cast<size_t>(j);
      if (message.active[i] == 0) continue;
      any = true;
      const core::Joint& joint = model_.joints[i];
      const double goal = message.position[i];
      if (!std::isfinite(goal) || goal < joint.position_min || goal > joint.position_max) {
        throw core::MessageError(info.channel, "position" + Index(j),
                                 core::FormatNumber(goal) + " is outside joint " +
                                     std::to_string(j + 1) + "'s limits [" +
                                     core::FormatNumber(joint.position_min) + ", " +
                                     core::FormatNumber(joint.position_max) + "]");
      }
      const double speed = message.max_velocity[i];
      const double acceleration = message.acceleration[i];
      if (!std::isfinite(speed) || speed < 0 || !std::isfinite(acceleration) || acceleration < 0) {
        throw core::MessageError(info.channel, "max_velocity/acceleration" + Index(j),
                                 core::FormatNumber(speed) + ", " +
                                     core::FormatNumber(acceleration) +
                                     ": allowed finite values >= 0 (0 = the joint's default)");
      }
      moves[i] = {true, goal,
                  speed > 0 ? std::min(speed, joint.velocity_max) : joint.servo.default_velocity,
                  acceleration > 0 ? acceleration : joint.servo.default_acceleration};
    }
    if (!any) throw core::MessageError(info.channel, "active", "no joint is active");
  } catch (const core::MessageError& error) {
    Refuse(error);
    throw;  // counted as rejected on ARM_TARGET
  }
  last_error_.clear();
  StartMove(moves);
  PublishStatus(true);
}

void ControlNode::OnPoseTarget(const sirupp::pose_target_t& message,
                               const core::ReceiveInfo& info) {
  const int n = model_.num_joints();
  std::vector<JointMove> moves(static_cast<size_t>(n));
  try {
    RequireManual(info.channel);
    for (int i = 0; i < 3; ++i) {
      if (!std::isfinite(message.position[i])) {
        throw core::MessageError(
            info.channel, "position" + Index(i),
            core::FormatNumber(message.position[i]) + ": allowed finite metres");
      }
    }
    const Eigen::Quaterniond q(message.orientation[0], message.orientation[1],
                               message.orientation[2], message.orientation[3]);
    const double norm = q.norm();
    if (message.position_only == 0 && (!std::isfinite(norm) || std::abs(norm - 1) > 1e-3)) {
      throw core::MessageError(info.channel, "orientation",
                               "quaternion norm " + core::FormatNumber(norm) +
                                   ": allowed a unit quaternion (w, x, y, z), norm 1 +- 0.001");
    }
    if (message.position_only != 0 && message.position_only != 1) {
      throw core::MessageError(info.channel, "position_only",
                               std::to_string(message.position_only) + ": allowed 0 or 1");
    }
    const auto check_enum = [&](const char* field, int8_t value) {
      if (value < 0 || value > 2) {
        throw core::MessageError(info.channel, field,
                                 std::to_string(value) + ": allowed 0 (any), 1 or 2");
      }
    };
    check_enum("shoulder", message.shoulder);
    check_enum("elbow", message.elbow);
    check_enum("wrist", message.wrist);
    const double scale = message.speed_scale == 0 ? 1.0 : message.speed_scale;
    if (!std::isfinite(scale) || scale <= 0 || scale > 1) {
      throw core::MessageError(
          info.channel, "speed_scale",
          core::FormatNumber(message.speed_scale) + ": allowed (0, 1], or 0 for 1");
    }
    if (!servos_on_) {
      throw core::MessageError(info.channel, "",
                               "no arm state yet on " + options_.channels.sim_arm_state +
                                   ": the IK needs the present joints (is sirupp-sim running?)");
    }
    PoseRequest request;
    request.target.translation() << message.position[0], message.position[1], message.position[2];
    if (message.position_only == 0) request.target.linear() = q.normalized().toRotationMatrix();
    request.position_only = message.position_only == 1;
    using Pose = sirupp::pose_target_t;
    if (message.shoulder != Pose::SHOULDER_ANY) {
      request.shoulder_left = message.shoulder == Pose::SHOULDER_LEFT;
    }
    if (message.elbow != Pose::ELBOW_ANY) request.elbow_up = message.elbow == Pose::ELBOW_UP;
    if (message.wrist != Pose::WRIST_ANY) request.wrist_flip = message.wrist == Pose::WRIST_FLIP;
    const PoseGoal goal = SolvePoseGoal(model_, request, core::ToJointVector(positions_));
    if (!goal.ok) {
      throw core::MessageError(info.channel, "position/orientation",
                               "no joint solution: " + goal.reason);
    }
    for (int j = 0; j < n; ++j) {
      const core::Joint& joint = model_.joints[static_cast<size_t>(j)];
      moves[static_cast<size_t>(j)] = {true, goal.q[j], joint.servo.default_velocity * scale,
                                       joint.servo.default_acceleration * scale};
    }
  } catch (const core::MessageError& error) {
    Refuse(error);
    throw;
  }
  last_error_.clear();
  StartMove(moves);
  PublishStatus(true);
}

void ControlNode::OnPlan(const sirupp::plan_command_t& message, const core::ReceiveInfo& info) {
  using Command = sirupp::plan_command_t;
  try {
    switch (message.command) {
      case Command::COMMAND_RUN: {
        const std::string name = message.name.empty() ? "plan" : message.name;
        RequireNoEstop(info.channel, "run " + name);
        if (plan_running_) {
          throw core::MessageError(info.channel, "command",
                                   "run " + name + ": plan " + plan_->name +
                                       " is still running; abort it first (sirupp plan abort)");
        }
        if (!servos_on_) {
          throw core::MessageError(info.channel, "command",
                                   "run " + name + ": no arm state yet on " +
                                       options_.channels.sim_arm_state +
                                       " (is sirupp-sim running?)");
        }
        std::vector<double> start(static_cast<size_t>(model_.num_joints()));
        for (int j = 0; j < model_.num_joints(); ++j) start[static_cast<size_t>(j)] = bank_.Goal(j);
        try {
          plan_ = ParsePlan(message.text, name, model_, start);
        } catch (const core::ConfigError& error) {
          throw core::MessageError(info.channel, "text", error.what());
        }
        plan_running_ = true;
        plan_step_ = 0;
        plan_paused_ = false;
        wait_until_utime_ = -1;
        last_error_.clear();
        std::cerr << "sirupp-control: running plan " << plan_->name << " (" << plan_->steps.size()
                  << " steps)\n";
        break;
      }
      case Command::COMMAND_PAUSE:
        if (!plan_running_ || plan_paused_) {
          throw core::MessageError(info.channel, "command",
                                   "pause: no plan is running" +
                                       std::string(plan_paused_ ? " (it is paused already)" : ""));
        }
        plan_paused_ = true;
        paused_at_utime_ = last_state_utime_;
        break;
      case Command::COMMAND_RESUME:
        RequireNoEstop(info.channel, "resume");
        if (!plan_running_ || !plan_paused_) {
          throw core::MessageError(info.channel, "command", "resume: no plan is paused");
        }
        plan_paused_ = false;
        if (wait_until_utime_ >= 0) wait_until_utime_ += last_state_utime_ - paused_at_utime_;
        break;
      case Command::COMMAND_ABORT:
        // Also the stop button: the arm decelerates smoothly to rest whether a plan runs or not.
        bank_.StopSmooth();
        PublishStop(sirupp::servo_move_t::COMMAND_STOP_SMOOTH);
        if (plan_running_) EndPlan("");
        break;
      case Command::COMMAND_MANUAL:
        locked_automatic_ = false;
        if (plan_running_) {
          bank_.StopSmooth();
          PublishStop(sirupp::servo_move_t::COMMAND_STOP_SMOOTH);
          EndPlan("");
        }
        break;
      case Command::COMMAND_AUTOMATIC:
        locked_automatic_ = true;
        break;
      default:
        throw core::MessageError(info.channel, "command",
                                 std::to_string(message.command) +
                                     ": allowed 0..5 (run, pause, "
                                     "resume, abort, manual, "
                                     "automatic)");
    }
  } catch (const core::MessageError& error) {
    Refuse(error);
    throw;
  }
  PublishStatus(true);
}

void ControlNode::OnGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info) {
  const int n = model_.num_joints();
  std::vector<ServoGains> gains(static_cast<size_t>(n));
  try {
    CheckJointCount(info.channel, message.num_joints);
    const std::string& channel = info.channel;
    for (int j = 0; j < n; ++j) {
      const auto i = static_cast<size_t>(j);
      ServoGains& g = gains[i];
      g.kp = WholeGain(channel, "kp", j, message.kp[i], 0, 32767);
      g.kd = WholeGain(channel, "kd", j, message.kd[i], 0, 32767);
      g.ki = WholeGain(channel, "ki", j, message.ki[i], 0, 32767);
      g.integration_limit =
          WholeGain(channel, "integration_limit", j, message.integration_limit[i], 0, 32767);
      g.output_limit = WholeGain(channel, "output_limit", j, message.output_limit[i], 0, 255);
      WholeGain(channel, "current_limit", j, message.current_limit[i], 0, 255);
      g.error_limit = WholeGain(channel, "error_limit", j, message.error_limit[i], 0, 16383);
      g.deadband = WholeGain(channel, "deadband", j, message.deadband[i], 0, 255);
      if (message.servo_rate_divisor[i] != 1) {
        throw core::MessageError(channel, "servo_rate_divisor" + Index(j),
                                 core::FormatNumber(message.servo_rate_divisor[i]) +
                                     ": the virtual servos run every physics tick; allowed 1");
      }
      try {
        servo::CheckGains(g);
      } catch (const std::invalid_argument& error) {
        throw core::MessageError(channel, "joint" + Index(j), error.what());
      }
    }
  } catch (const core::MessageError& error) {
    Refuse(error);
    throw;
  }
  for (int j = 0; j < n; ++j) bank_.SetGains(j, gains[static_cast<size_t>(j)]);
  std::cerr << "sirupp-control: new gains, joint 1 Kp " << gains[0].kp << " Kd " << gains[0].kd
            << " Ki " << gains[0].ki << "\n";
  last_error_.clear();
  PublishStatus(true);
}

void ControlNode::AdvancePlan(int64_t utime) {
  if (!plan_running_ || plan_paused_) return;
  const auto steps = static_cast<int>(plan_->steps.size());
  while (plan_step_ < steps) {
    const PlanStep& step = plan_->steps[static_cast<size_t>(plan_step_)];
    if (step.kind == PlanStep::Kind::kWaitDone) {
      if (!bank_.AllDone()) return;
    } else if (step.kind == PlanStep::Kind::kWaitTime) {
      if (wait_until_utime_ < 0) {
        wait_until_utime_ = utime + static_cast<int64_t>(std::llround(step.wait_s * 1e6));
      }
      if (utime < wait_until_utime_) return;
      wait_until_utime_ = -1;
    } else {
      StartMove(step.moves);
    }
    ++plan_step_;
    PublishStatus(true);
  }
  if (bank_.AllDone()) EndPlan("");  // the plan ends when its last move is done
}

void ControlNode::EndPlan(const std::string& error) {
  plan_running_ = false;
  plan_paused_ = false;
  wait_until_utime_ = -1;
  if (!error.empty()) last_error_ = error;
  std::cerr << "sirupp-control: plan " << plan_->name
            << (error.empty() && plan_step_ >= static_cast<int>(plan_->steps.size())
                    ? " finished"
                    : " ended at step " + std::to_string(plan_step_ + 1))
            << "\n";
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
    if (plan_running_) EndPlan("");
    PublishStatus(true);
    return false;
  }
  return true;
}

int ControlNode::TrippedJoint() const {
  for (int j = 0; j < bank_.num_joints(); ++j) {
    if (bank_.servo(j).status() & servo::kPositionError) return j;
  }
  return -1;
}

int8_t ControlNode::mode() const {
  return plan_running_ || locked_automatic_ ? Status::MODE_AUTOMATIC : Status::MODE_MANUAL;
}

int8_t ControlNode::state() const {
  if (!servos_on_) return Status::STATE_OFF;
  if (law_failed_ || TrippedJoint() >= 0) return Status::STATE_FAULT;
  if (plan_running_ && plan_paused_) return Status::STATE_PAUSED;
  if (!bank_.AllDone()) return Status::STATE_MOVING;
  if (plan_running_) return Status::STATE_WAITING;
  return Status::STATE_IDLE;
}

void ControlNode::PublishStatus(bool force) {
  const int8_t now_state = state();
  const Clock::time_point now = Clock::now();
  if (!force && now_state == last_reported_state_ &&
      std::chrono::duration<double>(now - last_status_).count() < kStatusPeriodS) {
    return;
  }
  Status status{};
  status.utime = last_state_utime_;
  status.seq = status_seq_++;
  status.mode = mode();
  status.state = now_state;
  status.move_id = move_id_;
  status.plan_step = -1;
  if (plan_) {
    const auto steps = static_cast<int>(plan_->steps.size());
    status.plan_name = plan_->name;
    status.plan_step = plan_step_;
    status.plan_steps = steps;
    status.plan_line = plan_step_ < steps ? plan_->steps[static_cast<size_t>(plan_step_)].line : 0;
  }
  status.last_error = last_error_;
  bus_.Publish(options_.channels.controller_status, status);
  last_reported_state_ = now_state;
  last_status_ = now;
}

void ControlNode::Service(int max_wait_ms) {
  bus_.HandleAvailable();
  bus_.Handle(max_wait_ms);
  PublishStatus(false);
  const bool fault = state() == Status::STATE_FAULT;
  heartbeat_.PublishIfDue(fault ? core::ProcessState::kFault : core::ProcessState::kRunning,
                          fault ? last_error_ : "");
}

}  // namespace sirupp::control
