#pragma once
// The sequencer of sirupp-control, without transport: plans, modes, the emergency stop, joint and
// tool targets, faults and move ids, over the virtual PIC-SERVOs (ServoBank). Events come in as
// plain structs (commands already decoded from their messages, the arm's state); what is to be
// sent comes out as plain structs: the answer to each state (efforts for the sim), and, in order,
// the moves and stops for ARM_MOVE, the statuses for CONTROLLER_STATUS and lines for the log
// (TakeOutputs). No bus, no threads, no clock: time is the sim time of the states. ControlNode
// (control_node.hpp) is its transport shell.
//
// Modes: MANUAL takes targets; a plan run switches to AUTOMATIC until the plan ends or is aborted.
// PlanAction::kAutomatic also locks out targets with no plan running (until kManual). Anything
// refused is thrown as core::MessageError naming the command's `source` (its channel), after the
// refusal was made the last error and a status was queued; nothing moves then. Estop stops the arm
// at once where it is (kStopAbrupt), aborts a plan and refuses targets and plan runs until
// released. A servo that trips its position-error limit, a failing student's law, a move the
// bridge refused, a lost or restarted sim: each aborts the plan (a fault also brakes the arm until
// kClearFault); the next accepted target or plan switches the servos on again where the arm is.

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "control/boards.hpp"
#include "control/effort_law.hpp"
#include "control/plan.hpp"
#include "control/servo_bank.hpp"
#include "core/arm_state.hpp"
#include "core/messages.hpp"
#include "core/motion_limits.hpp"
#include "core/robot_model.hpp"

namespace sirupp::control {

// The values are those of controller_status_t::MODE_* and STATE_*, plan_command_t::COMMAND_* and
// servo_move_t::COMMAND_* (control_node.cpp checks that they agree).
enum class ControlMode : int8_t { kManual = 0, kAutomatic = 1 };
enum class ControlState : int8_t {
  kIdle = 0,     // servos holding, nothing to do
  kMoving = 1,   // a move is in progress
  kWaiting = 2,  // a plan waits (for a time or for move-done)
  kPaused = 3,
  kFault = 4,  // see last_error
  kOff = 5,    // no arm state yet: servos off
};
// plan_command_t::COMMAND_*: kRun, kPause, kResume, kAbort (also the stop button: a smooth stop
// whether a plan runs or not), kManual, kAutomatic, kClearFault.
using PlanAction = core::PlanAction;
enum class MoveKind : int8_t { kMove = 0, kStopSmooth = 1, kStopAbrupt = 2 };

// arm_state_t::FLAG_BRAKED: the sim holds the joint with its brake.
inline constexpr int8_t kFlagBraked = 8;

// Commands, as core/translate.hpp decoded them from their messages (counts, finiteness, ranges and
// enum values are checked there); what needs the model or the controller's state is checked here.
// `source` names where the command came from (the channel) in refusals.
struct JointTargetCommand {
  std::string source;
  std::vector<core::JointGoal> joints;  // SI; an inactive joint keeps its present move
};

struct PoseTargetCommand {
  std::string source;
  core::PoseTarget target;  // speed_scale 0 means 1
};

struct PlanCommand {
  std::string source;
  PlanAction action = PlanAction::kRun;
  std::string name;  // kRun: the plan's name in messages ("plan" when empty)
  std::string text;  // kRun: the plan (docs/plan-format.md)
};

struct EstopCommand {
  bool engaged = false;
  std::string sender;
  std::string reason;
};

// Outputs, in the order they happened.
struct MoveOrder {  // one ARM_MOVE
  MoveKind kind = MoveKind::kMove;
  int64_t move_id = 0;
  int64_t utime = 0;             // sim time of the latest state
  std::vector<JointMove> moves;  // one per joint; a stop holds every joint at its set-point
};

struct StatusReport {  // one CONTROLLER_STATUS
  int64_t utime = 0;
  ControlMode mode = ControlMode::kManual;
  ControlState state = ControlState::kOff;
  int64_t move_id = 0;
  std::string plan_name;  // empty, and plan_step -1, when no plan was loaded
  int plan_step = -1;
  int plan_steps = 0;
  int plan_line = 0;  // of the next step; 0 when the plan has ended
  std::string last_error;
};

struct LogNote {  // one line for stderr, without the process name
  std::string text;
};

using SequencerOutput = std::variant<MoveOrder, StatusReport, LogNote>;

// One joint's servo as ARM_SETPOINT shows it, SI.
struct JointSetpoint {
  double position = 0;
  double velocity = 0;
  double goal = 0;
  double position_error = 0;
  uint8_t status = 0;  // the PIC-SERVO status byte
};

struct SequencerOptions {
  std::string name = "sirupp-control";         // the answers' sender (the sim's participant name)
  std::string state_source = "SIM_ARM_STATE";  // where states come from, in messages
  // A student's controller in place of the PID filter; null = the PIC-SERVO PID (effort_law.hpp).
  std::shared_ptr<EffortLaw> effort_law;
  // The virtual boards run in sirupp-sim (control/boards.hpp): the sequencer takes their status
  // at each exchange (OnBoardStatus) and sends its moves, stops and servo-ons as board commands
  // (TakeBoardCommands) instead of ticking them itself with every state (OnState). Not with a
  // student's law, which needs the profiles here every tick.
  bool boards_remote = false;
};

class Sequencer {
 public:
  Sequencer(const core::RobotModel& model, SequencerOptions options);

  // --- Events in.
  // The arm's state; returns the efforts answering it. nullopt: the same tick again (the sim did
  // not get the answer): the caller sends its previous answer again. A smaller tick than the
  // last is a new sim run: the plan is aborted, the real arm stopped, the new state taken.
  std::optional<core::ArmCommand> OnState(const core::ArmState& state);
  // Remote boards: the arm's state and the boards' status at an exchange tick, and the last board
  // command they applied; returns the answer (MODE_BOARDS, or hold on a fault). nullopt and a new
  // sim run as OnState. The plan advances, faults and trips are seen once per exchange.
  std::optional<core::ArmCommand> OnBoardStatus(const core::ArmState& state,
                                                const core::ServoSetpoint& boards,
                                                int64_t command_seq);
  // Commands; each throws core::MessageError naming `source` when refused.
  void Target(const JointTargetCommand& command);
  void PoseTarget(const PoseTargetCommand& command);
  void Plan(const PlanCommand& command);
  // A check every plan passes before it runs (the sim's environment: ControlNode): it throws
  // core::ConfigError naming the plan's line to refuse the plan. None by default.
  using PlanCheck =
      std::function<void(const control::Plan& plan, const std::vector<double>& start)>;
  void SetPlanCheck(PlanCheck check) { plan_check_ = std::move(check); }
  // New gains for every joint (already checked); what changed goes to the log.
  void SetGains(const std::vector<ServoGains>& gains);
  void Estop(const EstopCommand& command);
  // No state for `silent_s` (the caller's clock): the sim is lost until the next state.
  void SimLost(double silent_s);
  // The bridge refused our latest move (`reason`): the virtual arm stops too.
  void MoveRefused(const std::string& reason);
  // A fault: the arm is braked (HOLD), a plan is aborted; the first cause is kept (later ones are
  // consequences) until kClearFault.
  void Fault(const std::string& cause);
  // A command the caller refused before it got here (it could not be decoded): made the last
  // error, with a status.
  void Refused(const std::string& error);
  // The bridge to the real arm was lost while linked (control_node.hpp): the virtual arm goes on;
  // `text` is logged and made the last error. RealArmBack: heard again; a last error that was the
  // loss is replaced by `text`.
  void RealArmLost(const std::string& text);
  void RealArmBack(const std::string& text);
  // Throws MessageError on `source` unless another model may be taken now: servos on or off but
  // idle (no move, no plan loaded and not ended, no fault, no e-stop, no student's law).
  void RequireModelChangeAllowed(const std::string& source) const;
  // Takes `model` (same arm, checked by the caller) in place: servos, limits and IK follow it, the
  // servos keep holding where they are (ServoBank::ReplaceModel); a status and a log line.
  void ReplaceModel(const core::RobotModel& model);

  // --- Out.
  // What happened since the last call, in order.
  std::vector<SequencerOutput> TakeOutputs();
  // Remote boards: the commands for SIM_BOARD_COMMAND since the last call, in order (send them
  // before the answer to the next exchange, after the ARM_MOVE outputs).
  std::vector<core::ServoMove> TakeBoardCommands() { return bank_.TakeCommands(); }
  StatusReport Status() const;
  std::vector<JointSetpoint> Setpoints() const;

  // --- Queries.
  ControlMode mode() const;
  ControlState state() const;
  // The boards as this process runs them (remote boards: only the gains in force are kept here).
  const ServoBank& servos() const { return bank_.local(); }
  bool boards_remote() const { return bank_.remote(); }
  const std::string& fault() const { return fault_; }
  const std::string& last_error() const { return last_error_; }
  const std::string& estop() const { return estop_; }  // who engaged it and why; empty = released
  int64_t move_id() const { return move_id_; }
  int64_t utime() const { return last_state_utime_; }  // of the latest state
  // Nothing was moved yet (no move, no plan): a wrong robot then refuses the start instead.
  bool untouched() const { return move_id_ == 0 && !plan_running_; }
  bool has_state() const { return last_tick_ >= 0; }
  bool sim_lost() const { return sim_lost_; }
  const control::Plan* plan() const { return plan_ ? &*plan_ : nullptr; }
  int plan_step() const { return plan_step_; }
  bool plan_running() const { return plan_running_; }
  bool plan_paused() const { return plan_paused_; }

 private:
  void ClearFault();
  // Throws MessageError on `source` while a fault is latched or the sim is lost.
  void RequireNoFault(const std::string& source, const std::string& what) const;
  // Throws MessageError on `source` while the emergency stop is engaged.
  void RequireNoEstop(const std::string& source, const std::string& what) const;
  // Throws MessageError on `source` if targets are not taken now (automatic mode, e-stop, fault).
  void RequireManual(const std::string& source) const;
  // Throws MessageError on `source` if a move breaks the motion limits the bridge applies.
  void CheckMotionLimits(const std::string& source, const std::vector<JointMove>& moves) const;
  // A target's moves from make_moves(), checked and started; refused (rethrown) in automatic mode,
  // under an e-stop or a fault, or when make_moves() or the motion limits refuse it.
  void TakeTarget(const std::string& source,
                  const std::function<std::vector<JointMove>()>& make_moves);
  std::vector<JointMove> JointTargetMoves(const JointTargetCommand& command) const;
  std::vector<JointMove> PoseTargetMoves(const PoseTargetCommand& command) const;
  void RunPlan(const PlanCommand& command);
  void PausePlan(const std::string& source);
  void ResumePlan(const std::string& source);
  void StopSmooth();  // the servos and the real arm (ARM_MOVE) decelerate to rest
  void OnSimRestart(int64_t from_tick, int64_t to_tick);
  // Takes the state's positions; switches the servos on at the first state.
  void TakeState(const core::ArmState& state);
  // This tick's efforts (plan advanced, servos ticked, the student's law asked); kHold on a fault.
  core::ArmCommand Efforts(const core::ArmState& state);
  void CheckTrip(int64_t tick);
  // Loads the moves into the servos (or keeps them until the first state) and sends them.
  void StartMove(const std::vector<JointMove>& moves);
  // A stop for every joint, at its present set-point.
  void SendStop(MoveKind kind);
  // Runs plan steps due at sim time `utime` (once per tick before the servos tick).
  void AdvancePlan(int64_t utime);
  void EndPlan(const std::string& error);
  // `cause` ends a running plan ("...; plan NAME aborted"), or is the last error when none runs.
  void AbortPlanOrReport(const std::string& cause);
  // Records a refusal: the last error, a status; the caller rethrows.
  void Refuse(const std::string& error);
  void SendStatus() { outputs_.emplace_back(Status()); }
  void Note(std::string text) { outputs_.emplace_back(LogNote{std::move(text)}); }
  // Efforts from the student's law for this tick; false (and a fault) if it failed.
  bool StudentEfforts(const core::ArmState& state, std::vector<double>& effort);

  core::RobotModel model_;
  SequencerOptions options_;
  Boards bank_;
  core::MotionLimits motion_limits_;  // the bridge's rule (core/motion_limits.hpp)
  std::vector<SequencerOutput> outputs_;

  // The arm.
  bool servos_on_ = false;
  std::vector<JointMove> pending_;  // a target that arrived before the first arm state
  std::vector<double> positions_;   // the last measured joint positions
  int64_t last_tick_ = -1;
  int64_t last_state_utime_ = 0;
  std::vector<double> last_effort_;  // the last answer's efforts, held while the sim brakes
  bool have_last_effort_ = false;
  bool sim_lost_ = false;

  // Modes, plan, e-stop, faults.
  std::string fault_;
  std::string estop_;
  bool locked_automatic_ = false;  // kAutomatic given (until kManual)
  std::optional<control::Plan> plan_;
  PlanCheck plan_check_;
  bool plan_running_ = false;  // from kRun until its last move is done, an abort or a fault
  int plan_step_ = 0;          // next step to run; == steps.size() when the plan has ended
  bool plan_paused_ = false;
  int64_t wait_until_utime_ = -1;  // end of the present `wait SECONDS`, -1 when none
  int64_t paused_at_utime_ = 0;
  bool trip_reported_ = false;
  int64_t move_id_ = 0;
  std::string last_error_;

  // The student's law.
  bool law_reset_ = false;
  bool law_failed_ = false;  // it threw or returned a non-finite effort: arm held
  ControlInput law_input_;
};

}  // namespace sirupp::control
