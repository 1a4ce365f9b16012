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
#include "core/model_check.hpp"
#include "core/motion_limits.hpp"
#include "core/translate.hpp"
#include "servo/chip_gains.hpp"

namespace sirupp::control {
namespace {

std::string Index(int j) { return "[" + std::to_string(j) + "]"; }

using Clock = std::chrono::steady_clock;
using Status = sirupp::controller_status_t;

constexpr double kStatusPeriodS = 0.1;  // CONTROLLER_STATUS at 10 Hz (and on every change)

}  // namespace

ControlNode::ControlNode(core::Bus& bus, const core::RobotModel& model, ControlOptions options)
    : bus_(bus),
      model_(model),
      options_(std::move(options)),
      bank_(model),
      heartbeat_(bus, options_.name, options_.channels.heartbeat),
      replier_(bus, options_.channels.controller_reply, options_.name),
      chip_gains_(servo::ChipGainsFromModel(model)),
      motion_limits_(core::DefaultMotionLimits(model)) {
  const core::Channels& channels = options_.channels;
  bus_.Subscribe<sirupp::arm_state_t>(
      channels.sim_arm_state,
      [this](const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
        OnState(message, info);
      },
      1000);
  // Each command gets one answer on CONTROLLER_REPLY naming it (core/command_reply.hpp).
  bus_.Subscribe<sirupp::joint_target_t>(
      channels.arm_target,
      [this](const sirupp::joint_target_t& message, const core::ReceiveInfo& info) {
        replier_.Answer(
            message, info, [&] { OnTarget(message, info); }, [this] { return Facts(true); });
      });
  bus_.Subscribe<sirupp::pose_target_t>(
      channels.arm_pose_target,
      [this](const sirupp::pose_target_t& message, const core::ReceiveInfo& info) {
        replier_.Answer(
            message, info, [&] { OnPoseTarget(message, info); }, [this] { return Facts(true); });
      });
  bus_.Subscribe<sirupp::plan_command_t>(
      channels.arm_plan,
      [this](const sirupp::plan_command_t& message, const core::ReceiveInfo& info) {
        const bool run = message.command == sirupp::plan_command_t::COMMAND_RUN;
        replier_.Answer(
            message, info, [&] { OnPlan(message, info); }, [this, run] { return Facts(run); });
      });
  bus_.Subscribe<sirupp::servo_gains_t>(
      channels.arm_gains,
      [this](const sirupp::servo_gains_t& message, const core::ReceiveInfo& info) {
        replier_.Answer(
            message, info, [&] { OnGains(message, info); }, [this] { return Facts(false); });
      });
  bus_.Subscribe<sirupp::estop_t>(
      channels.estop, [this](const sirupp::estop_t& message, const core::ReceiveInfo& info) {
        OnEstop(message, info);
      });
  bus_.Subscribe<sirupp::command_reply_t>(
      channels.hardware_reply, [this](const sirupp::command_reply_t& message,
                                      const core::ReceiveInfo&) { OnBridgeReply(message); });
  bus_.Subscribe<sirupp::robot_model_t>(
      channels.robot_model, [this](const sirupp::robot_model_t& message,
                                   const core::ReceiveInfo& info) { OnModel(message, info); });
  heartbeat_.Publish(core::ProcessState::kStarting, "");
}

void ControlNode::OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info) {
  if (!model_checked_.empty() && message.source_hash == model_checked_) return;
  // Only a model that is one (it builds and passes the loader's checks) can refuse ours: a
  // malformed message is refused and counted, it never stops this controller.
  core::RobotModelFromMessage(message, info.channel);
  const std::string mismatch = core::ModelMismatch(model_, message, options_.name);
  if (mismatch.empty()) {
    model_checked_ = message.source_hash;
    return;
  }
  if (move_id_ == 0 && !plan_running_) {
    start_refusal_ = mismatch;
  } else if (fault_.find(mismatch) == std::string::npos) {
    Fault(mismatch);
  }
}

void ControlNode::Fault(const std::string& cause) {
  if (fault_.empty()) {
    fault_ = cause;
    std::cerr << "sirupp-control: fault: " << cause
              << "; the arm is held until the fault is cleared (sirupp clear-fault)\n";
  } else {
    std::cerr << "sirupp-control: consequence of the fault (" << fault_ << "): " << cause << "\n";
  }
  pending_.clear();
  if (servos_on_) bank_.StopSmooth();
  AbortPlanOrReport(fault_);
}

void ControlNode::ClearFault() {
  if (fault_.empty() && TrippedJoint() < 0 && !law_failed_) return;
  std::cerr << "sirupp-control: fault cleared"
            << (fault_.empty() ? std::string() : " (it was: " + fault_ + ")")
            << "; servos on where the arm is\n";
  fault_.clear();
  law_failed_ = false;
  law_reset_ = false;  // the student's law starts afresh (Reset) at the next tick
  trip_reported_ = false;
  if (servos_on_) bank_.ServoOn(positions_);
  last_error_.clear();
}

void ControlNode::RequireNoFault(const std::string& channel, const std::string& what) const {
  if (!fault_.empty()) {
    throw core::MessageError(channel, "",
                             what + ": the controller is faulted: " + fault_ +
                                 "; clear the fault first (sirupp clear-fault)");
  }
  if (sim_lost_) {
    throw core::MessageError(channel, "",
                             what + ": no state from sirupp-sim on " +
                                 options_.channels.sim_arm_state +
                                 " (is it running?); the arm cannot be moved");
  }
}

void ControlNode::OnSimRestart(int64_t from_tick, int64_t to_tick) {
  const std::string cause = "sirupp-sim restarted (its tick went from " +
                            std::to_string(from_tick) + " back to " + std::to_string(to_tick) +
                            "): the arm is taken where the new sim has it";
  std::cerr << "sirupp-control: " << cause << "\n";
  pending_.clear();
  servos_on_ = false;  // switched on again at the new state's positions
  have_last_command_ = false;
  law_reset_ = false;
  // The real arm must not finish a move the virtual one no longer makes.
  PublishStop(sirupp::servo_move_t::COMMAND_STOP_SMOOTH);
  AbortPlanOrReport(cause);
}

void ControlNode::CheckSimAlive() {
  if (sim_lost_ || last_tick_ < 0) return;
  const double silent_s = std::chrono::duration<double>(Clock::now() - last_state_wall_).count();
  if (silent_s < options_.sim_timeout_s) return;
  sim_lost_ = true;
  const std::string cause = "no state from sirupp-sim on " + options_.channels.sim_arm_state +
                            " for " + core::FormatNumber(options_.sim_timeout_s) +
                            " s: the sim is lost (stopped, crashed or stalled)";
  std::cerr << "sirupp-control: " << cause << "; the real arm is stopped\n";
  if (servos_on_) bank_.StopSmooth();
  PublishStop(sirupp::servo_move_t::COMMAND_STOP_SMOOTH);
  AbortPlanOrReport(cause);
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
  AbortPlanOrReport(estop_);
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
  last_state_wall_ = Clock::now();
  if (sim_lost_) {
    sim_lost_ = false;
    std::cerr << "sirupp-control: states from sirupp-sim again (tick " << state.tick << ")\n";
    if (last_error_.rfind("no state from sirupp-sim", 0) == 0) last_error_.clear();
  }
  if (state.tick == last_tick_) {
    // The same state again: the sim did not get our answer (lost) or re-sent it; answer again.
    if (have_last_command_) {
      last_command_.seq = command_seq_++;
      bus_.Publish(options_.channels.sim_arm_command, last_command_);
    }
    return;
  }
  if (state.tick < last_tick_) OnSimRestart(last_tick_, state.tick);
  last_tick_ = state.tick;
  last_state_utime_ = state.utime;
  positions_ = state.position;
  if (!servos_on_) {
    bank_.ServoOn(state.position);
    servos_on_ = true;
    if (!pending_.empty()) bank_.Load(pending_);
    pending_.clear();
  }
  // Held by the sim (a silent participant, an e-stop, our own hold): the profiles wait where they
  // are, so a brake nobody here asked for cannot trip a servo (docs/timing.md).
  const bool braked = std::any_of(state.flags.begin(), state.flags.end(), [](int8_t flags) {
    return (flags & sirupp::arm_state_t::FLAG_BRAKED) != 0;
  });

  core::ArmCommand command;
  command.utime = state.utime;
  command.tick = state.tick;
  command.sender = options_.name;
  command.mode = core::CommandMode::kEffort;
  if (!fault_.empty()) {
    command.mode = core::CommandMode::kHold;
    command.effort.assign(static_cast<size_t>(model_.num_joints()), 0.0);
  } else if (braked && have_last_command_) {
    command.effort = last_command_.effort;  // what held the arm before the brake, until released
  } else {
    AdvancePlan(state.utime);
    command.effort = bank_.Tick(state.position);
    if (options_.effort_law && !StudentEfforts(state, command.effort)) {
      command.mode = core::CommandMode::kHold;
      command.effort.assign(command.effort.size(), 0.0);
    }
  }
  last_command_ = core::ToMessage(command, command_seq_++);
  have_last_command_ = true;
  bus_.Publish(options_.channels.sim_arm_command, last_command_);
  ++states_answered_;
  // The sim's next state waits for this answer: its silence counts from here, so a controller
  // library that took long (up to its call limit) does not make the sim look lost.
  last_state_wall_ = Clock::now();

  const int tripped = TrippedJoint();
  if (tripped >= 0 && !trip_reported_) {
    trip_reported_ = true;
    const PicServo& servo = bank_.servo(tripped);
    Fault("joint j" + std::to_string(tripped + 1) + " tripped its position-error limit (" +
          std::to_string(servo.gains().error_limit) + " counts) at tick " +
          std::to_string(state.tick) + ": the arm is braked");
  }
  if (options_.publish_setpoints) PublishSetpoint(state, command.effort);
}

void ControlNode::PublishSetpoint(const core::ArmState& state, const std::vector<double>& effort) {
  core::ServoSetpoint setpoint;
  setpoint.utime = state.utime;
  setpoint.seq = setpoint_seq_++;
  setpoint.tick = state.tick;
  setpoint.move_id = move_id_;
  for (int j = 0; j < model_.num_joints(); ++j) {
    const PicServo& servo = bank_.servo(j);
    const JointDrive& drive = bank_.drive(j);
    core::JointSetpoint joint;
    joint.position = bank_.SetpointPosition(j);
    joint.velocity = bank_.SetpointVelocity(j);
    joint.goal = bank_.Goal(j);
    joint.position_error = static_cast<double>(servo.position_error()) / drive.counts_per_unit();
    joint.effort = effort[static_cast<size_t>(j)];
    joint.status = static_cast<int8_t>(servo.status());
    setpoint.joints.push_back(joint);
  }
  bus_.Publish(options_.channels.arm_setpoint, core::ToMessage(setpoint));
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
  RequireNoFault(channel, "target");
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

void ControlNode::CheckMotionLimits(const std::string& channel,
                                    const std::vector<JointMove>& moves) const {
  for (int j = 0; j < static_cast<int>(moves.size()); ++j) {
    const JointMove& move = moves[static_cast<size_t>(j)];
    if (!move.active) continue;
    if (const auto reason = core::CheckJointMove(model_, motion_limits_, j, move.goal,
                                                 move.velocity, move.acceleration)) {
      throw core::MessageError(channel, "joint[" + std::to_string(j) + "]",
                               *reason + " (the real arm's bridge refuses it too)");
    }
  }
}

void ControlNode::OnBridgeReply(const sirupp::command_reply_t& reply) {
  // The bridge's answer to our latest ARM_MOVE, matched by its channel, utime and seq: the
  // virtual arm must not make a move the real one refused.
  if (reply.result != sirupp::command_reply_t::RESULT_REFUSED || move_seq_ == 0 ||
      !core::RepliesTo(reply, bus_.FullName(options_.channels.arm_move), last_move_utime_,
                       move_seq_ - 1)) {
    return;
  }
  const std::string cause =
      "sirupp-hardware refused move " + std::to_string(move_id_) + " (" + reply.error + ")";
  std::cerr << "sirupp-control: " << cause << "; the virtual arm stops too\n";
  if (servos_on_) bank_.StopSmooth();
  PublishStop(sirupp::servo_move_t::COMMAND_STOP_SMOOTH);
  AbortPlanOrReport(cause);
}

void ControlNode::StartMove(const std::vector<JointMove>& moves) {
  if (servos_on_) {
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
  last_move_utime_ = move.utime;
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
    CheckMotionLimits(info.channel, moves);
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
    CheckMotionLimits(info.channel, moves);
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
        RequireNoFault(info.channel, "run " + name);
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
        RequireNoFault(info.channel, "resume");
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
      case Command::COMMAND_CLEAR_FAULT:
        ClearFault();
        break;
      default:
        throw core::MessageError(info.channel, "command",
                                 std::to_string(message.command) +
                                     ": allowed 0..6 (run, pause, resume, abort, manual, "
                                     "automatic, clear-fault)");
    }
  } catch (const core::MessageError& error) {
    Refuse(error);
    throw;
  }
  PublishStatus(true);
}

void ControlNode::OnGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info) {
  const int n = model_.num_joints();
  std::vector<ServoGains> gains;
  try {
    chip_gains_ = servo::ChipGainsFromMessage(message, model_, info.channel);
  } catch (const core::MessageError& error) {
    Refuse(error);
    throw;
  }
  for (const servo::ChipGains& chip : chip_gains_) gains.push_back(servo::ToServoGains(chip));
  std::string changed;
  for (int j = 0; j < n; ++j) {
    const ServoGains& now = bank_.servo(j).gains();
    const ServoGains& next = gains[static_cast<size_t>(j)];
    if (now.kp != next.kp || now.kd != next.kd || now.ki != next.ki) {
      changed += " j" + std::to_string(j + 1) + " Kp " + std::to_string(next.kp) + " Kd " +
                 std::to_string(next.kd) + " Ki " + std::to_string(next.ki) + ";";
    }
    bank_.SetGains(j, next);
  }
  std::cerr << "sirupp-control: new gains:" << (changed.empty() ? " Kp, Kd, Ki as before" : changed)
            << "\n";
  last_error_.clear();
  gains_changed_ = true;
  PublishGains(true);
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

void ControlNode::AbortPlanOrReport(const std::string& cause) {
  if (plan_running_) {
    EndPlan(cause + "; plan " + plan_->name + " aborted");
  } else {
    last_error_ = cause;
    PublishStatus(true);
  }
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
    Fault("controller '" + name + "' at tick " + std::to_string(state.tick) + ": " + error.what());
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
  if (!fault_.empty() || law_failed_ || TrippedJoint() >= 0 || sim_lost_) {
    return Status::STATE_FAULT;
  }
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
  core::ControllerStatus status;
  status.utime = last_state_utime_;
  status.seq = status_seq_++;
  status.mode = static_cast<core::ControllerMode>(mode());
  status.state = static_cast<core::ControllerState>(now_state);
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
  bus_.Publish(options_.channels.controller_status, core::ToMessage(status));
  last_reported_state_ = now_state;
  last_status_ = now;
}

core::ReplyFacts ControlNode::Facts(bool moves) const {
  core::ReplyFacts facts;
  facts.move_id = moves ? move_id_ : -1;
  facts.status_seq = status_seq_ - 1;  // every handler sends a status before it returns or throws
  return facts;
}

void ControlNode::PublishGains(bool force) {
  const Clock::time_point now = Clock::now();
  if (!force && !gains_changed_ && std::chrono::duration<double>(now - last_gains_).count() < 1.0) {
    return;
  }
  sirupp::servo_gains_t message = servo::GainsMessage(chip_gains_);
  message.utime = last_state_utime_;
  message.seq = gains_seq_++;
  bus_.Publish(options_.channels.controller_gains, message);
  last_gains_ = now;
  gains_changed_ = false;
}

void ControlNode::Service(int max_wait_ms) {
  bus_.HandleAvailable();
  bus_.Handle(max_wait_ms);
  CheckSimAlive();
  PublishGains(false);
  PublishStatus(false);
  const bool fault = state() == Status::STATE_FAULT;
  heartbeat_.PublishIfDue(fault ? core::ProcessState::kFault : core::ProcessState::kRunning,
                          fault ? last_error_ : "");
}

}  // namespace sirupp::control
