#include "control/control_node.hpp"

#include <cstdio>
#include <iostream>
#include <optional>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <variant>

#include "control/plan_collision.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/model_check.hpp"
#include "core/real_arm_note.hpp"
#include "core/translate.hpp"
#include "servo/chip_gains.hpp"

namespace sirupp::control {
namespace {

using Clock = std::chrono::steady_clock;
using Move = sirupp::servo_move_t;
using PlanMessage = sirupp::plan_command_t;

constexpr double kStatusPeriodS = 0.1;  // CONTROLLER_STATUS at 10 Hz (and on every change)

// The sequencer's enums carry the messages' values.
static_assert(static_cast<int8_t>(ControlMode::kAutomatic) ==
              sirupp::controller_status_t::MODE_AUTOMATIC);
static_assert(static_cast<int8_t>(ControlState::kWaiting) ==
              sirupp::controller_status_t::STATE_WAITING);
static_assert(static_cast<int8_t>(ControlState::kOff) == sirupp::controller_status_t::STATE_OFF);
static_assert(static_cast<int8_t>(MoveKind::kStopSmooth) == Move::COMMAND_STOP_SMOOTH);
static_assert(static_cast<int8_t>(MoveKind::kStopAbrupt) == Move::COMMAND_STOP_ABRUPT);
static_assert(static_cast<int8_t>(PlanAction::kAbort) == PlanMessage::COMMAND_ABORT);
static_assert(static_cast<int8_t>(PlanAction::kClearFault) == PlanMessage::COMMAND_CLEAR_FAULT);
static_assert(static_cast<int>(MoveKind::kStopAbrupt) ==
              static_cast<int>(core::MoveCommand::kStopAbrupt));
static_assert(kFlagBraked == sirupp::arm_state_t::FLAG_BRAKED);
static_assert(static_cast<int>(ControlState::kOff) ==
              static_cast<int>(core::ControllerState::kOff));
static_assert(static_cast<int>(ControlMode::kAutomatic) ==
              static_cast<int>(core::ControllerMode::kAutomatic));

}  // namespace

ControlNode::ControlNode(core::Bus& bus, const core::RobotModel& model, ControlOptions options)
    : bus_(bus),
      model_(model),
      options_(std::move(options)),
      sequencer_(model, {options_.name,
                         options_.boards_in_sim && !options_.effort_law
                             ? options_.channels.sim_board_status.name()
                             : options_.channels.sim_arm_state.name(),
                         options_.effort_law, options_.boards_in_sim}),
      heartbeat_(bus, options_.name, options_.channels.heartbeat),
      replier_(bus, options_.channels.controller_reply, options_.name),
      chip_gains_(servo::ChipGainsFromModel(model)) {
  if (!options_.clock) {
    throw std::invalid_argument(
        "sirupp-control: ControlOptions::clock is empty; leave it at the "
        "steady clock or give a clock that returns the time");
  }
  const core::Channels& channels = options_.channels;
  using Info = core::ReceiveInfo;
  sequencer_.SetPlanCheck([this](const Plan& plan, const std::vector<double>& start) {
    CheckPlanInEnvironment(plan, start);
  });
  bus_.Subscribe<sirupp::environment_t>(
      channels.environment, [this](const sirupp::environment_t& message, const Info& info) {
        OnEnvironment(message, info);
      });
  if (sequencer_.boards_remote()) {
    bus_.Subscribe<sirupp::board_status_t>(
        channels.sim_board_status,
        [this](const sirupp::board_status_t& message, const Info& info) {
          OnBoardStatus(message, info);
        },
        100);
  } else {
    bus_.Subscribe<sirupp::arm_state_t>(
        channels.sim_arm_state,
        [this](const sirupp::arm_state_t& message, const Info& info) { OnState(message, info); },
        1000);
  }
  // Each command gets one answer on CONTROLLER_REPLY naming it (core/command_reply.hpp). Each is
  // decoded by its core/translate.hpp pair; a message it refuses is the sequencer's last error too.
  // While a model is being loaded (model_switch.hpp) nothing may start a move.
  bus_.Subscribe<sirupp::joint_target_t>(
      channels.arm_target, [this](const sirupp::joint_target_t& message, const Info& info) {
        Answer(message, info, true, [&] {
          const std::vector<core::JointGoal> joints =
              Decoded(core::JointTargetFromMessage, message, info.channel).joints;
          model_switch_.RequireNone(info.channel, Now());
          sequencer_.Target({info.channel, joints});
        });
      });
  bus_.Subscribe<sirupp::pose_target_t>(
      channels.arm_pose_target, [this](const sirupp::pose_target_t& message, const Info& info) {
        Answer(message, info, true, [&] {
          const core::PoseTarget target =
              Decoded(core::PoseTargetFromMessage, message, info.channel);
          model_switch_.RequireNone(info.channel, Now());
          sequencer_.PoseTarget({info.channel, target});
        });
      });
  bus_.Subscribe<sirupp::plan_command_t>(
      channels.arm_plan, [this](const sirupp::plan_command_t& message, const Info& info) {
        Answer(message, info, message.command == PlanMessage::COMMAND_RUN, [&] {
          const core::PlanCommand plan =
              Decoded(core::PlanCommandFromMessage, message, info.channel);
          if (plan.command == core::PlanAction::kLoadModel) {
            if (!plan.text.empty()) sequencer_.RequireModelChangeAllowed(info.channel);
            model_switch_.Request(info.channel, plan.name, plan.text, model_, Now());
            return;
          }
          if (plan.command == core::PlanAction::kRun) {
            model_switch_.RequireNone(info.channel, Now());
          }
          sequencer_.Plan({info.channel, plan.command, plan.name, plan.text});
        });
      });
  bus_.Subscribe<sirupp::servo_gains_t>(
      channels.arm_gains, [this](const sirupp::servo_gains_t& message, const Info& info) {
        Answer(message, info, false, [&] { OnGains(message, info); });
      });
  bus_.Subscribe<sirupp::estop_t>(
      channels.estop, [this](const sirupp::estop_t& message, const Info& info) {
        const core::EStop estop = core::EStopFromMessage(message, info.channel);
        sequencer_.Estop({estop.engaged, estop.sender, estop.reason});
        Flush();
      });
  bus_.Subscribe<sirupp::command_reply_t>(
      channels.hardware_reply, [this](const sirupp::command_reply_t& message, const Info& info) {
        OnBridgeReply(message, info);
      });
  bus_.Subscribe<sirupp::robot_model_t>(
      channels.robot_model,
      [this](const sirupp::robot_model_t& message, const Info& info) { OnModel(message, info); });
  bus_.Subscribe<sirupp::hardware_status_t>(
      channels.hardware_status, [this](const sirupp::hardware_status_t& message, const Info& info) {
        // Only a status a bridge could have sent counts; others are refused (and counted).
        core::HardwareStatusFromMessage(message, info.channel);
        OnBridgeStatus(message);
      });
  // The states are read in this thread from a socket of their own (udpm), without LCM's hand-over
  // from its receive thread: one wake-up per tick (core/bus.hpp, ReadDirectly).
  bus_.ReadDirectly({bus_.FullName(sequencer_.boards_remote() ? channels.sim_board_status.name()
                                                              : channels.sim_arm_state.name())},
                    options_.name);
  heartbeat_.Publish(core::ProcessState::kStarting, "");
}

template <class Value, class Msg>
Value ControlNode::Decoded(Value (*from_message)(const Msg&, const std::string&),
                           const Msg& message, const std::string& channel) {
  try {
    return from_message(message, channel);
  } catch (const core::MessageError& error) {
    sequencer_.Refused(error.what());  // the last error, with a status; nothing moves
    throw;
  }
}

template <class Msg, class Handle>
void ControlNode::Answer(const Msg& message, const core::ReceiveInfo& info, bool moves,
                         Handle&& handle) {
  // The sequencer's statuses go out before the reply, which names the last of them.
  replier_.Answer(
      message, info,
      [&] {
        try {
          handle();
        } catch (...) {
          Flush();
          throw;  // counted as rejected on the channel
        }
        Flush();
      },
      [this, moves] { return Facts(moves); });
}

void ControlNode::OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info) {
  if (!model_checked_.empty() && message.source_hash == model_checked_) return;
  if (std::optional<core::RobotModel> announced = model_switch_.Take(message, Now())) {
    // The model this controller agreed to take (ARM_PLAN COMMAND_LOAD_MODEL), now the sim's.
    core::RobotModelFromMessage(message, info.channel);
    model_ = std::move(*announced);
    sequencer_.ReplaceModel(model_);
    model_checked_ = message.source_hash;
    Flush();
    return;
  }
  // Only a model that is one (it builds and passes the loader's checks) can refuse ours: a
  // malformed message is refused and counted, it never stops this controller.
  core::RobotModelFromMessage(message, info.channel);
  const std::string mismatch = core::ModelMismatch(model_, message, options_.name);
  if (mismatch.empty()) {
    model_checked_ = message.source_hash;
    return;
  }
  if (sequencer_.untouched()) {
    start_refusal_ = mismatch;
  } else if (sequencer_.fault().find(mismatch) == std::string::npos) {
    sequencer_.Fault(mismatch);
    Flush();
  }
}

void ControlNode::OnGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info) {
  try {
    chip_gains_ = servo::ChipGainsFromMessage(message, model_, info.channel);
  } catch (const core::MessageError& error) {
    sequencer_.Refused(error.what());
    throw;
  }
  std::vector<ServoGains> gains;
  for (const servo::ChipGains& chip : chip_gains_) gains.push_back(servo::ToServoGains(chip));
  sequencer_.SetGains(gains);
  gains_changed_ = true;
  PublishGains(true);
}

void ControlNode::OnBridgeReply(const sirupp::command_reply_t& message,
                                const core::ReceiveInfo& info) {
  const core::CommandReply reply = core::CommandReplyFromMessage(message, info.channel);
  // The bridge's answer to our latest ARM_MOVE, matched by its channel, utime and seq: the
  // virtual arm must not make a move the real one refused.
  if (reply.accepted || move_seq_ == 0 ||
      !core::RepliesTo(message, bus_.FullName(options_.channels.arm_move), last_move_utime_,
                       move_seq_ - 1)) {
    return;
  }
  sequencer_.MoveRefused(reply.error);
  Flush();
}

void ControlNode::OnEnvironment(const sirupp::environment_t& message,
                                const core::ReceiveInfo& info) {
  // A message that does not decode is counted as rejected on the channel (the bus names it); the
  // last good environment stays.
  environment_ = core::EnvironmentFromMessage(message, info.channel);
}

void ControlNode::CheckPlanInEnvironment(const Plan& plan, const std::vector<double>& start) {
  if (!environment_ || environment_->objects.empty()) return;
  planning::CollisionModel collision(model_, *environment_, {});
  const PlanCollisionReport report =
      CheckPlanCollisions(model_, plan, start, collision, kPlanCheckStepRad);
  if (!report.error) return;
  const planning::SweepFinding& finding = *report.error;
  const PlanStep* step =
      finding.step < 0 ? nullptr : &plan.steps[static_cast<size_t>(finding.step)];
  throw core::ConfigError(
      {plan.name, step == nullptr ? 0 : step->line, 0}, "",
      (step == nullptr ? "at the start" : "'" + step->text + "'") +
          std::string(finding.contact.kind == planning::ContactKind::kSelf
                          ? ": the arm hits itself: "
                          : ": collision: ") +
          FindingDetail(model_, collision, finding) + " (the sim's environment " +
          environment_->name +
          "; `sirupp plan check --env` shows the whole plan, `sirupp plan make` plans around it)");
}

void ControlNode::CheckSimAlive() {
  if (sequencer_.sim_lost() || !sequencer_.has_state()) return;
  const double silent_s = std::chrono::duration<double>(Now() - last_state_wall_).count();
  if (silent_s < options_.sim_timeout_s) return;
  sequencer_.SimLost(options_.sim_timeout_s);
  Flush();
}

void ControlNode::OnBridgeStatus(const sirupp::hardware_status_t& message) {
  last_bridge_status_ = Now();
  bridge_linked_ = message.state == sirupp::hardware_status_t::STATE_LINKED;
  if (bridge_lost_) {
    bridge_lost_ = false;
    sequencer_.RealArmBack(std::string(core::kRealArmLost) + "sirupp-hardware heard again (" +
                           (bridge_linked_ ? "linked" : "not linked") + ")");
    Flush();
  }
}

void ControlNode::CheckBridgeAlive() {
  if (!bridge_linked_ || bridge_lost_) return;
  const double silent_s = std::chrono::duration<double>(Now() - last_bridge_status_).count();
  if (silent_s < options_.bridge_timeout_s) return;
  bridge_lost_ = true;
  bridge_linked_ = false;
  char at[32];
  std::snprintf(at, sizeof at, "%.3f", static_cast<double>(sequencer_.utime()) * 1e-6);
  sequencer_.RealArmLost(std::string(core::kRealArmLost) + "sirupp-hardware lost at t = " + at +
                         " s (no HARDWARE_STATUS for " +
                         core::FormatNumber(options_.bridge_timeout_s) +
                         " s while linked); the boards finish the loaded move alone, the run is "
                         "incomplete for the real arm");
  Flush();
}

void ControlNode::OnState(const sirupp::arm_state_t& message, const core::ReceiveInfo& info) {
  const core::ArmState state =
      core::ArmStateFromMessage(message, info.channel, model_.num_joints());
  last_state_wall_ = Now();
  const std::optional<core::ArmCommand> command = sequencer_.OnState(state);
  Flush();
  SendAnswer(command);
  if (command && options_.publish_setpoints) PublishSetpoint(state, command->effort);
}

void ControlNode::OnBoardStatus(const sirupp::board_status_t& message,
                                const core::ReceiveInfo& info) {
  const core::BoardStatus status =
      core::BoardStatusFromMessage(message, info.channel, model_.num_joints());
  last_state_wall_ = Now();
  const std::optional<core::ArmCommand> command =
      sequencer_.OnBoardStatus(status.arm, status.boards, status.command_seq);
  Flush();  // the board commands of this exchange go out before the answer
  SendAnswer(command);
}

void ControlNode::SendAnswer(const std::optional<core::ArmCommand>& command) {
  if (!command) {
    // The same state again: the sim did not get our answer (lost) or re-sent it; answer again.
    if (have_last_command_) {
      last_command_.seq = command_seq_++;
      bus_.Publish(options_.channels.sim_arm_command, last_command_);
    }
    return;
  }
  last_command_ = core::ToMessage(*command, command_seq_++);
  have_last_command_ = true;
  bus_.Publish(options_.channels.sim_arm_command, last_command_);
  ++states_answered_;
  // The sim's next state waits for this answer: its silence counts from here, so a controller
  // library that took long (up to its call limit) does not make the sim look lost.
  last_state_wall_ = Now();
}

void ControlNode::Flush() {
  for (const SequencerOutput& output : sequencer_.TakeOutputs()) {
    std::visit(
        [this](const auto& item) {
          using T = std::decay_t<decltype(item)>;
          if constexpr (std::is_same_v<T, MoveOrder>) {
            PublishMove(item);
          } else if constexpr (std::is_same_v<T, StatusReport>) {
            PublishStatus(item);
          } else {
            std::cerr << "sirupp-control: " << item.text << "\n";
          }
        },
        output);
  }
  for (const core::ServoMove& command : sequencer_.TakeBoardCommands()) {
    bus_.Publish(options_.channels.sim_board_command, core::ToMessage(command));
  }
}

void ControlNode::PublishSetpoint(const core::ArmState& state, const std::vector<double>& effort) {
  core::ServoSetpoint setpoint;
  setpoint.utime = state.utime;
  setpoint.seq = setpoint_seq_++;
  setpoint.tick = state.tick;
  setpoint.move_id = sequencer_.move_id();
  const std::vector<JointSetpoint> joints = sequencer_.Setpoints();
  for (size_t j = 0; j < joints.size(); ++j) {
    core::JointSetpoint joint;
    joint.position = joints[j].position;
    joint.velocity = joints[j].velocity;
    joint.goal = joints[j].goal;
    joint.position_error = joints[j].position_error;
    joint.effort = effort[j];
    joint.status = static_cast<int8_t>(joints[j].status);
    setpoint.joints.push_back(joint);
  }
  bus_.Publish(options_.channels.arm_setpoint, core::ToMessage(setpoint));
}

void ControlNode::PublishMove(const MoveOrder& order) {
  core::ServoMove move;
  move.utime = order.utime;
  move.seq = move_seq_++;
  last_move_utime_ = move.utime;
  move.move_id = order.move_id;
  move.command = static_cast<core::MoveCommand>(order.kind);
  for (const JointMove& joint_move : order.moves) {
    move.joints.push_back({joint_move.goal, joint_move.velocity, joint_move.acceleration,
                           static_cast<int8_t>(joint_move.active ? Move::FLAG_ACTIVE : 0)});
  }
  bus_.Publish(options_.channels.arm_move, core::ToMessage(move));
}

int8_t ControlNode::mode() const { return static_cast<int8_t>(sequencer_.mode()); }

int8_t ControlNode::state() const { return static_cast<int8_t>(sequencer_.state()); }

void ControlNode::PublishStatus(const StatusReport& report) {
  core::ControllerStatus status;
  status.utime = report.utime;
  status.seq = status_seq_++;
  status.mode = static_cast<core::ControllerMode>(report.mode);
  status.state = static_cast<core::ControllerState>(report.state);
  status.move_id = report.move_id;
  status.plan_name = report.plan_name;
  status.plan_step = report.plan_step;
  status.plan_steps = report.plan_steps;
  status.plan_line = report.plan_line;
  status.last_error = report.last_error;
  bus_.Publish(options_.channels.controller_status, core::ToMessage(status));
  last_reported_state_ = static_cast<int8_t>(report.state);
  last_status_ = Now();
}

void ControlNode::PublishStatusIfDue() {
  if (state() == last_reported_state_ &&
      std::chrono::duration<double>(Now() - last_status_).count() < kStatusPeriodS) {
    return;
  }
  PublishStatus(sequencer_.Status());
}

core::ReplyFacts ControlNode::Facts(bool moves) const {
  core::ReplyFacts facts;
  facts.move_id = moves ? sequencer_.move_id() : -1;
  facts.status_seq = status_seq_ - 1;  // every handler sends a status before it returns or throws
  return facts;
}

void ControlNode::PublishGains(bool force) {
  const Clock::time_point now = Now();
  if (!force && !gains_changed_ && std::chrono::duration<double>(now - last_gains_).count() < 1.0) {
    return;
  }
  sirupp::servo_gains_t message = servo::GainsMessage(chip_gains_);
  message.utime = sequencer_.utime();
  message.seq = gains_seq_++;
  bus_.Publish(options_.channels.controller_gains, message);
  last_gains_ = now;
  gains_changed_ = false;
}

void ControlNode::Service(int max_wait_ms) {
  // Reading the states directly, Handle takes every state waiting and one message of LCM's per
  // call, returning at once when something waits: a HandleAvailable first would cost one more
  // poll per tick to find nothing.
  if (!bus_.reads_directly()) bus_.HandleAvailable();
  bus_.Handle(max_wait_ms);
  CheckSimAlive();
  CheckBridgeAlive();
  PublishGains(false);
  PublishStatusIfDue();
  const bool fault = sequencer_.state() == ControlState::kFault;
  heartbeat_.PublishIfDue(fault ? core::ProcessState::kFault : core::ProcessState::kRunning,
                          fault ? sequencer_.last_error() : "");
}

}  // namespace sirupp::control
