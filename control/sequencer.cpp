#include "control/sequencer.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <utility>

#include "control/pose_goal.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/real_arm_note.hpp"
#include "core/translate.hpp"

namespace sirupp::control {
namespace {

std::string Index(int j) { return "[" + std::to_string(j) + "]"; }

// A pose target (checked field by field by core::PoseTargetFromMessage) as SolvePoseGoal's request.
PoseRequest ToPoseRequest(const core::PoseTarget& target) {
  PoseRequest request;
  request.target.translation() = target.position;
  if (!target.position_only)
    request.target.linear() = target.orientation.normalized().toRotationMatrix();
  request.position_only = target.position_only;
  if (target.shoulder != core::ArmChoice::kAny) {
    request.shoulder_left = target.shoulder == core::ArmChoice::kFirst;
  }
  if (target.elbow != core::ArmChoice::kAny)
    request.elbow_up = target.elbow == core::ArmChoice::kFirst;
  if (target.wrist != core::ArmChoice::kAny) {
    request.wrist_flip = target.wrist == core::ArmChoice::kSecond;
  }
  return request;
}

}  // namespace

Sequencer::Sequencer(const core::RobotModel& model, SequencerOptions options)
    : model_(model),
      options_(std::move(options)),
      bank_(model, options_.boards_remote && !options_.effort_law),
      motion_limits_(core::DefaultMotionLimits(model)) {}

std::vector<SequencerOutput> Sequencer::TakeOutputs() {
  std::vector<SequencerOutput> taken;
  taken.swap(outputs_);
  return taken;
}

// --- The arm's state.

std::optional<core::ArmCommand> Sequencer::OnState(const core::ArmState& state) {
  if (sim_lost_) {
    sim_lost_ = false;
    Note("states from sirupp-sim again (tick " + std::to_string(state.tick) + ")");
    if (last_error_.rfind("no state from sirupp-sim", 0) == 0) last_error_.clear();
  }
  // The same state again: the sim did not get our answer (lost) or re-sent it.
  if (state.tick == last_tick_) return std::nullopt;
  if (state.tick < last_tick_) OnSimRestart(last_tick_, state.tick);
  TakeState(state);
  core::ArmCommand command = Efforts(state);
  last_effort_ = command.effort;
  have_last_effort_ = true;
  CheckTrip(state.tick);
  return command;
}

std::optional<core::ArmCommand> Sequencer::OnBoardStatus(const core::ArmState& state,
                                                         const core::ServoSetpoint& boards,
                                                         int64_t command_seq) {
  if (!bank_.remote()) {
    throw std::logic_error("Sequencer::OnBoardStatus: the boards run here (OnState)");
  }
  if (sim_lost_) {
    sim_lost_ = false;
    Note("states from sirupp-sim again (tick " + std::to_string(state.tick) + ")");
    if (last_error_.rfind("no state from sirupp-sim", 0) == 0) last_error_.clear();
  }
  if (state.tick == last_tick_) return std::nullopt;
  if (state.tick < last_tick_) OnSimRestart(last_tick_, state.tick);
  bank_.TakeStatus(boards, command_seq);
  TakeState(state);
  core::ArmCommand command;
  command.utime = state.utime;
  command.tick = state.tick;
  command.sender = options_.name;
  command.mode = core::CommandMode::kBoards;
  command.effort.assign(static_cast<size_t>(model_.num_joints()), 0.0);
  // Held by the sim (a silent participant, an e-stop): the boards wait there, and the plan here.
  const bool braked = std::any_of(state.flags.begin(), state.flags.end(),
                                  [](int8_t flags) { return (flags & kFlagBraked) != 0; });
  if (fault_.empty() && !braked) AdvancePlan(state.utime);
  CheckTrip(state.tick);
  if (!fault_.empty()) command.mode = core::CommandMode::kHold;
  return command;
}

void Sequencer::TakeState(const core::ArmState& state) {
  last_tick_ = state.tick;
  last_state_utime_ = state.utime;
  positions_ = state.position;
  if (!servos_on_) {
    bank_.ServoOn(state.position);
    servos_on_ = true;
    if (!pending_.empty()) bank_.Load(pending_);
    pending_.clear();
  }
}

core::ArmCommand Sequencer::Efforts(const core::ArmState& state) {
  // Held by the sim (a silent participant, an e-stop, our own hold): the profiles wait where they
  // are, so a brake nobody here asked for cannot trip a servo (docs/timing.md).
  const bool braked = std::any_of(state.flags.begin(), state.flags.end(),
                                  [](int8_t flags) { return (flags & kFlagBraked) != 0; });
  core::ArmCommand command;
  command.utime = state.utime;
  command.tick = state.tick;
  command.sender = options_.name;
  command.mode = core::CommandMode::kEffort;
  if (!fault_.empty()) {
    command.mode = core::CommandMode::kHold;
    command.effort.assign(static_cast<size_t>(model_.num_joints()), 0.0);
  } else if (braked && have_last_effort_) {
    command.effort = last_effort_;  // what held the arm before the brake, until released
  } else {
    AdvancePlan(state.utime);
    command.effort = bank_.Tick(state.position);
    if (options_.effort_law && !StudentEfforts(state, command.effort)) {
      command.mode = core::CommandMode::kHold;
      command.effort.assign(command.effort.size(), 0.0);
    }
  }
  return command;
}

void Sequencer::CheckTrip(int64_t tick) {
  const int tripped = bank_.TrippedJoint();
  if (tripped < 0 || trip_reported_) return;
  trip_reported_ = true;
  Fault("joint j" + std::to_string(tripped + 1) + " tripped its position-error limit (" +
        std::to_string(bank_.Gains(tripped).error_limit) + " counts) at tick " +
        std::to_string(tick) + ": the arm is braked");
}

void Sequencer::OnSimRestart(int64_t from_tick, int64_t to_tick) {
  const std::string cause = "sirupp-sim restarted (its tick went from " +
                            std::to_string(from_tick) + " back to " + std::to_string(to_tick) +
                            "): the arm is taken where the new sim has it";
  Note(cause);
  pending_.clear();
  servos_on_ = false;  // switched on again at the new state's positions
  have_last_effort_ = false;
  law_reset_ = false;
  // The real arm must not finish a move the virtual one no longer makes.
  SendStop(MoveKind::kStopSmooth);
  AbortPlanOrReport(cause);
}

void Sequencer::SimLost(double silent_s) {
  if (sim_lost_ || !has_state()) return;
  sim_lost_ = true;
  const std::string cause = "no state from sirupp-sim on " + options_.state_source + " for " +
                            core::FormatNumber(silent_s) +
                            " s: the sim is lost (stopped, crashed or stalled)";
  Note(cause + "; the real arm is stopped");
  if (servos_on_) bank_.StopSmooth();
  SendStop(MoveKind::kStopSmooth);
  AbortPlanOrReport(cause);
}

bool Sequencer::StudentEfforts(const core::ArmState& state, std::vector<double>& effort) {
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

// --- Faults and the emergency stop.

void Sequencer::Fault(const std::string& cause) {
  if (fault_.empty()) {
    fault_ = cause;
    Note("fault: " + cause + "; the arm is held until the fault is cleared (sirupp clear-fault)");
  } else {
    Note("consequence of the fault (" + fault_ + "): " + cause);
  }
  pending_.clear();
  if (servos_on_) bank_.StopSmooth();
  AbortPlanOrReport(fault_);
}

void Sequencer::ClearFault() {
  if (fault_.empty() && bank_.TrippedJoint() < 0 && !law_failed_) return;
  Note("fault cleared" + (fault_.empty() ? std::string() : " (it was: " + fault_ + ")") +
       "; servos on where the arm is");
  fault_.clear();
  law_failed_ = false;
  law_reset_ = false;  // the student's law starts afresh (Reset) at the next tick
  trip_reported_ = false;
  if (servos_on_) bank_.ServoOn(positions_);
  last_error_.clear();
}

void Sequencer::RequireNoFault(const std::string& source, const std::string& what) const {
  if (!fault_.empty()) {
    throw core::MessageError(source, "",
                             what + ": the controller is faulted: " + fault_ +
                                 "; clear the fault first (sirupp clear-fault)");
  }
  if (sim_lost_) {
    throw core::MessageError(source, "",
                             what + ": no state from sirupp-sim on " + options_.state_source +
                                 " (is it running?); the arm cannot be moved");
  }
}

void Sequencer::Estop(const EstopCommand& command) {
  if (!command.engaged) {
    if (estop_.empty()) return;
    estop_.clear();
    last_error_.clear();
    SendStatus();
    return;
  }
  estop_ = "emergency stop from '" + command.sender + "': " + command.reason;
  if (servos_on_) bank_.ServoOn(positions_);  // command position = actual: held where it is
  pending_.clear();
  SendStop(MoveKind::kStopAbrupt);
  AbortPlanOrReport(estop_);
  Note(estop_);
}

void Sequencer::RequireNoEstop(const std::string& source, const std::string& what) const {
  if (!estop_.empty()) {
    throw core::MessageError(
        source, "",
        what + ": " + estop_ + " is engaged; release it first (sirupp estop --release)");
  }
}

void Sequencer::MoveRefused(const std::string& reason) {
  const std::string cause =
      "sirupp-hardware refused move " + std::to_string(move_id_) + " (" + reason + ")";
  Note(cause + "; the virtual arm stops too");
  if (servos_on_) bank_.StopSmooth();
  SendStop(MoveKind::kStopSmooth);
  AbortPlanOrReport(cause);
}

void Sequencer::Refuse(const std::string& error) {
  last_error_ = error;
  SendStatus();
}

void Sequencer::Refused(const std::string& error) { Refuse(error); }

void Sequencer::RealArmLost(const std::string& text) {
  Note(text);
  Refuse(text);
}

void Sequencer::RealArmBack(const std::string& text) {
  Note(text);
  if (last_error_.rfind(core::kRealArmLost, 0) == 0) Refuse("");
}

// --- Targets.

void Sequencer::RequireManual(const std::string& source) const {
  RequireNoEstop(source, "target");
  RequireNoFault(source, "target");
  if (plan_running_) {
    throw core::MessageError(source, "",
                             "plan " + plan_->name + " is running (step " +
                                 std::to_string(plan_step_ + 1) + " of " +
                                 std::to_string(plan_->steps.size()) +
                                 "); targets are taken in manual mode only: abort "
                                 "the plan first (sirupp plan abort)");
  }
  if (locked_automatic_) {
    throw core::MessageError(source, "",
                             "the controller is locked in automatic mode; targets are taken in "
                             "manual mode only (sirupp plan manual)");
  }
}

void Sequencer::CheckMotionLimits(const std::string& source,
                                  const std::vector<JointMove>& moves) const {
  for (int j = 0; j < static_cast<int>(moves.size()); ++j) {
    const JointMove& move = moves[static_cast<size_t>(j)];
    if (!move.active) continue;
    if (const auto reason = core::CheckJointMove(model_, motion_limits_, j, move.goal,
                                                 move.velocity, move.acceleration)) {
      throw core::MessageError(source, "joint[" + std::to_string(j) + "]",
                               *reason + " (the real arm's bridge refuses it too)");
    }
  }
}

std::vector<JointMove> Sequencer::JointTargetMoves(const JointTargetCommand& command) const {
  const std::string& source = command.source;
  const int n = model_.num_joints();
  core::CheckJointCount(source, "num_joints", command.joints.size(), n);
  std::vector<JointMove> moves(static_cast<size_t>(n));
  bool any = false;
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    const core::JointGoal& target = command.joints[i];
    if (!target.active) continue;
    any = true;
    const core::Joint& joint = model_.joints[i];
    if (target.position < joint.position_min || target.position > joint.position_max) {
      core::RefuseValue(source, "position" + Index(j), core::FormatNumber(target.position),
                        "within joint " + std::to_string(j + 1) + "'s limits [" +
                            core::FormatNumber(joint.position_min) + ", " +
                            core::FormatNumber(joint.position_max) + "]");
    }
    const double speed = target.max_velocity;
    const double acceleration = target.acceleration;
    moves[i] = {true, target.position,
                speed > 0 ? std::min(speed, joint.velocity_max) : joint.servo.default_velocity,
                acceleration > 0 ? acceleration : joint.servo.default_acceleration};
  }
  if (!any) core::RefuseValue(source, "active", "no active joint", "at least one joint active");
  return moves;
}

void Sequencer::Target(const JointTargetCommand& command) {
  TakeTarget(command.source, [&] { return JointTargetMoves(command); });
}

void Sequencer::TakeTarget(const std::string& source,
                           const std::function<std::vector<JointMove>()>& make_moves) {
  std::vector<JointMove> moves;
  try {
    RequireManual(source);
    moves = make_moves();
    CheckMotionLimits(source, moves);
  } catch (const core::MessageError& error) {
    Refuse(error.what());
    throw;
  }
  last_error_.clear();
  StartMove(moves);
  SendStatus();
}

std::vector<JointMove> Sequencer::PoseTargetMoves(const PoseTargetCommand& command) const {
  const double scale = command.target.speed_scale == 0 ? 1.0 : command.target.speed_scale;
  const PoseRequest request = ToPoseRequest(command.target);
  if (!servos_on_) {
    throw core::MessageError(command.source, "",
                             "no arm state yet on " + options_.state_source +
                                 ": the IK needs the present joints (is sirupp-sim running?)");
  }
  const PoseGoal goal = SolvePoseGoal(model_, request, core::ToJointVector(positions_));
  if (!goal.ok) {
    throw core::MessageError(command.source, "position/orientation",
                             "no joint solution: " + goal.reason);
  }
  std::vector<JointMove> moves(static_cast<size_t>(model_.num_joints()));
  for (int j = 0; j < model_.num_joints(); ++j) {
    const core::Joint& joint = model_.joints[static_cast<size_t>(j)];
    moves[static_cast<size_t>(j)] = {true, goal.q[j], joint.servo.default_velocity * scale,
                                     joint.servo.default_acceleration * scale};
  }
  return moves;
}

void Sequencer::PoseTarget(const PoseTargetCommand& command) {
  TakeTarget(command.source, [&] { return PoseTargetMoves(command); });
}

void Sequencer::SetGains(const std::vector<ServoGains>& gains) {
  std::string changed;
  for (int j = 0; j < model_.num_joints(); ++j) {
    const ServoGains& now = bank_.Gains(j);
    const ServoGains& next = gains.at(static_cast<size_t>(j));
    if (now.kp != next.kp || now.kd != next.kd || now.ki != next.ki) {
      changed += " j" + std::to_string(j + 1) + " Kp " + std::to_string(next.kp) + " Kd " +
                 std::to_string(next.kd) + " Ki " + std::to_string(next.ki) + ";";
    }
    bank_.SetGains(j, next);
  }
  Note("new gains:" + (changed.empty() ? std::string(" Kp, Kd, Ki as before") : changed));
  last_error_.clear();
  SendStatus();
}

// --- Plans and modes.

void Sequencer::Plan(const PlanCommand& command) {
  try {
    switch (command.action) {
      case PlanAction::kRun:
        RunPlan(command);
        break;
      case PlanAction::kPause:
        PausePlan(command.source);
        break;
      case PlanAction::kResume:
        ResumePlan(command.source);
        break;
      case PlanAction::kAbort:
        // Also the stop button: the arm decelerates smoothly to rest whether a plan runs or not.
        StopSmooth();
        if (plan_running_) EndPlan("");
        break;
      case PlanAction::kManual:
        locked_automatic_ = false;
        if (plan_running_) {
          StopSmooth();
          EndPlan("");
        }
        break;
      case PlanAction::kAutomatic:
        locked_automatic_ = true;
        break;
      case PlanAction::kClearFault:
        ClearFault();
        break;
      case PlanAction::kLoadModel:  // the transport's (ControlNode and model_switch.hpp)
        throw core::MessageError(command.source, "command",
                                 "load model: not a sequencer command (sirupp-control takes it)");
    }
  } catch (const core::MessageError& error) {
    Refuse(error.what());
    throw;
  }
  SendStatus();
}

void Sequencer::RunPlan(const PlanCommand& command) {
  const std::string& source = command.source;
  const std::string name = command.name.empty() ? "plan" : command.name;
  RequireNoEstop(source, "run " + name);
  RequireNoFault(source, "run " + name);
  if (plan_running_) {
    throw core::MessageError(source, "command",
                             "run " + name + ": plan " + plan_->name +
                                 " is still running; abort it first (sirupp plan abort)");
  }
  if (!servos_on_) {
    throw core::MessageError(source, "command",
                             "run " + name + ": no arm state yet on " + options_.state_source +
                                 " (is sirupp-sim running?)");
  }
  std::vector<double> start(static_cast<size_t>(model_.num_joints()));
  for (int j = 0; j < model_.num_joints(); ++j) start[static_cast<size_t>(j)] = bank_.Goal(j);
  try {
    control::Plan parsed = ParsePlan(command.text, name, model_, start);
    if (plan_check_) plan_check_(parsed, start);
    plan_ = std::move(parsed);
  } catch (const core::ConfigError& error) {
    throw core::MessageError(source, "text", error.what());
  }
  plan_running_ = true;
  plan_step_ = 0;
  plan_paused_ = false;
  wait_until_utime_ = -1;
  last_error_.clear();
  Note("running plan " + plan_->name + " (" + std::to_string(plan_->steps.size()) + " steps)");
}

void Sequencer::PausePlan(const std::string& source) {
  if (!plan_running_ || plan_paused_) {
    throw core::MessageError(
        source, "command",
        "pause: no plan is running" + std::string(plan_paused_ ? " (it is paused already)" : ""));
  }
  plan_paused_ = true;
  paused_at_utime_ = last_state_utime_;
}

void Sequencer::ResumePlan(const std::string& source) {
  RequireNoEstop(source, "resume");
  RequireNoFault(source, "resume");
  if (!plan_running_ || !plan_paused_) {
    throw core::MessageError(source, "command", "resume: no plan is paused");
  }
  plan_paused_ = false;
  // A `wait SECONDS` under way ends as much later as the pause lasted.
  if (wait_until_utime_ >= 0) wait_until_utime_ += last_state_utime_ - paused_at_utime_;
}

void Sequencer::StopSmooth() {
  bank_.StopSmooth();
  SendStop(MoveKind::kStopSmooth);
}

void Sequencer::AdvancePlan(int64_t utime) {
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
    SendStatus();
  }
  if (bank_.AllDone()) EndPlan("");  // the plan ends when its last move is done
}

void Sequencer::AbortPlanOrReport(const std::string& cause) {
  if (plan_running_) {
    EndPlan(cause + "; plan " + plan_->name + " aborted");
  } else {
    last_error_ = cause;
    SendStatus();
  }
}

void Sequencer::EndPlan(const std::string& error) {
  plan_running_ = false;
  plan_paused_ = false;
  wait_until_utime_ = -1;
  if (!error.empty()) last_error_ = error;
  Note("plan " + plan_->name +
       (error.empty() && plan_step_ >= static_cast<int>(plan_->steps.size())
            ? " finished"
            : " ended at step " + std::to_string(plan_step_ + 1)));
  SendStatus();
}

// --- Moves out.

void Sequencer::StartMove(const std::vector<JointMove>& moves) {
  bank_.set_move_id(move_id_ + 1);  // the id a remote board command carries
  if (servos_on_) {
    bank_.Load(moves);
  } else {
    pending_ = moves;  // loaded when the first arm state switches the servos on
  }
  ++move_id_;
  outputs_.emplace_back(MoveOrder{MoveKind::kMove, move_id_, last_state_utime_, moves});
}

void Sequencer::SendStop(MoveKind kind) {
  std::vector<JointMove> stops;
  for (int j = 0; j < model_.num_joints(); ++j) {
    const core::Joint& joint = model_.joints[static_cast<size_t>(j)];
    stops.push_back({true, bank_.SetpointPosition(j), joint.servo.default_velocity,
                     joint.servo.default_acceleration});
  }
  outputs_.emplace_back(MoveOrder{kind, move_id_, last_state_utime_, std::move(stops)});
}

// --- Status.

ControlMode Sequencer::mode() const {
  return plan_running_ || locked_automatic_ ? ControlMode::kAutomatic : ControlMode::kManual;
}

void Sequencer::RequireModelChangeAllowed(const std::string& source) const {
  const auto refuse = [&](const std::string& why) {
    throw core::MessageError(source, "command", "load model: " + why);
  };
  if (options_.effort_law)
    refuse("a student's controller runs, built for the model it started with");
  if (!estop_.empty()) refuse("the emergency stop is engaged (" + estop_ + "); release it first");
  if (plan_running_) refuse("plan '" + plan_->name + "' runs; abort it or let it end first");
  const ControlState now = state();
  if (now == ControlState::kFault) refuse("a fault holds the arm; clear it first");
  if (now == ControlState::kMoving) refuse("a move is in progress; wait for it to end");
}

void Sequencer::ReplaceModel(const core::RobotModel& model) {
  bank_.ReplaceModel(model, positions_, servos_on_);
  model_ = model;
  motion_limits_ = core::DefaultMotionLimits(model);
  have_last_effort_ = false;
  Note("now driving model '" + model.name + "' from " + model.source_file);
  SendStatus();
}

ControlState Sequencer::state() const {
  if (!servos_on_) return ControlState::kOff;
  if (!fault_.empty() || law_failed_ || bank_.TrippedJoint() >= 0 || sim_lost_) {
    return ControlState::kFault;
  }
  if (plan_running_ && plan_paused_) return ControlState::kPaused;
  if (!bank_.AllDone()) return ControlState::kMoving;
  if (plan_running_) return ControlState::kWaiting;
  return ControlState::kIdle;
}

StatusReport Sequencer::Status() const {
  StatusReport status;
  status.utime = last_state_utime_;
  status.mode = mode();
  status.state = state();
  status.move_id = move_id_;
  if (plan_) {
    const auto steps = static_cast<int>(plan_->steps.size());
    status.plan_name = plan_->name;
    status.plan_step = plan_step_;
    status.plan_steps = steps;
    status.plan_line = plan_step_ < steps ? plan_->steps[static_cast<size_t>(plan_step_)].line : 0;
  }
  status.last_error = last_error_;
  return status;
}

std::vector<JointSetpoint> Sequencer::Setpoints() const {
  std::vector<JointSetpoint> setpoints(static_cast<size_t>(bank_.num_joints()));
  for (int j = 0; j < bank_.num_joints(); ++j) {
    JointSetpoint& setpoint = setpoints[static_cast<size_t>(j)];
    setpoint.position = bank_.SetpointPosition(j);
    setpoint.velocity = bank_.SetpointVelocity(j);
    setpoint.goal = bank_.Goal(j);
    setpoint.position_error = bank_.PositionError(j);
    setpoint.status = bank_.Status(j);
  }
  return setpoints;
}

}  // namespace sirupp::control
