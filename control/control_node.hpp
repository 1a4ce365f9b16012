#pragma once
// The sirupp-control process over a core::Bus: the transport shell of the Sequencer
// (control/sequencer.hpp), which holds the plan, modes, e-stop, targets, faults and the virtual
// PIC-SERVOs. Each message is decoded into the sequencer's plain command, handed to it, and what
// it asks to send is encoded and published.
//
// In:  SIM_ARM_STATE (answered on SIM_ARM_COMMAND with the same tick, so sirupp-sim can run in
//      lockstep), ARM_TARGET (joint targets), ARM_POSE_TARGET (tool targets through IK), ARM_PLAN
//      (movement plans: run, pause, resume, abort; manual/automatic mode), ARM_GAINS (live gains),
//      ESTOP, HARDWARE_REPLY (a refusal of our latest ARM_MOVE), HARDWARE_STATUS (a linked bridge
//      that falls silent is lost: named in last_error), ROBOT_MODEL (the sim's robot;
//      another model announced on ARM_PLAN COMMAND_LOAD_MODEL is taken in place, model_switch.hpp),
//      ENVIRONMENT (the sim's objects: a plan whose set-points pass through a static one or
//      through the arm itself is refused before it runs, naming its line; plan_collision.hpp).
// Out: ARM_MOVE (every move and stop, as LOAD_TRAJ), ARM_SETPOINT (every tick), CONTROLLER_STATUS
//      (10 Hz and on every change), CONTROLLER_GAINS (1 Hz and on change), CONTROLLER_REPLY (one
//      answer per ARM_TARGET, ARM_POSE_TARGET, ARM_PLAN and ARM_GAINS, naming the request),
//      HEARTBEAT.
//
// With the boards in the sim (ControlOptions::boards_in_sim, no student's law): in SIM_BOARD_STATUS
//      (every exchange tick) in place of SIM_ARM_STATE, answered on SIM_ARM_COMMAND with
//      MODE_BOARDS (hold on a fault); out SIM_BOARD_COMMAND (the moves, stops and servo-ons for the
//      sim's boards, before that answer) in addition; the sim publishes ARM_SETPOINT then.
//
// What the node itself decides: the watchdogs on SIM_ARM_STATE (silent for sim_timeout_s = the sim
// is lost) and on a linked bridge's HARDWARE_STATUS (silent for bridge_timeout_s = the real arm is
// lost), the rates of the periodic messages, matching the bridge's reply to our latest ARM_MOVE,
// and whether the sim's robot is ours. The watchdogs and rates read ControlOptions::clock, the
// wall clock in every timing mode (docs/hardware.md, "A lost bridge is named"); a test moves its
// own. Anything refused is counted
// as rejected on its channel and named in the reply and last_error; nothing moves then.

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/board_status_t.hpp>
#include <sirupp/command_reply_t.hpp>
#include <sirupp/environment_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <string>
#include <vector>

#include "control/effort_law.hpp"
#include "control/model_switch.hpp"
#include "control/plan.hpp"
#include "control/sequencer.hpp"
#include "control/servo_bank.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/command_reply.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/heartbeat.hpp"
#include "core/robot_model.hpp"
#include "servo/chip_gains.hpp"

namespace sirupp::control {

struct ControlOptions {
  std::string name = "sirupp-control";  // arm_command_t.sender: the sim's participant name
  core::Channels channels;
  bool publish_setpoints = true;  // ARM_SETPOINT every tick (when the boards run here)
  // The virtual PIC-SERVO boards run in sirupp-sim beside the physics (sim/sim_node.hpp): this
  // node sends them moves and reads their status every exchange tick, as sirupp-hardware does
  // with the real boards, and no per-tick message passes between the two processes. Ignored with
  // a student's law (effort_law), which needs the profiles here every tick: the sim's boards are
  // then bypassed, as the chip's PWM mode bypasses its PID. sirupp-control's default
  // (--boards sim); false here keeps the library's per-tick loop for in-process tests.
  bool boards_in_sim = false;
  // A student's controller in place of the PID filter; null = the PIC-SERVO PID (effort_law.hpp).
  std::shared_ptr<EffortLaw> effort_law;
  // No SIM_ARM_STATE for this long (wall clock) = the sim is lost: a plan is aborted, the real
  // arm stopped (STOP_SMOOTH on ARM_MOVE), the status says so until states come again.
  double sim_timeout_s = 0.5;
  // No HARDWARE_STATUS (sent at 10 Hz) for this long (wall clock, in lockstep too: the bridge and
  // its boards run on the wall clock, not on the sim's time) while the bridge was linked = the
  // bridge is lost: the virtual arm goes on, last_error names the loss ("real arm: sirupp-hardware
  // lost at t = ...", t in sim time), the client marks the move or plan that was under way
  // incomplete for the real arm and the logger's end line names it, until the bridge is heard
  // again.
  double bridge_timeout_s = 0.6;
  // The clock of the node's own timing: both watchdogs above, the rates of CONTROLLER_STATUS and
  // CONTROLLER_GAINS, a model switch's time limit. The wall clock; a test gives one it moves.
  std::function<std::chrono::steady_clock::time_point()> clock = [] {
    return std::chrono::steady_clock::now();
  };
};

class ControlNode {
 public:
  ControlNode(core::Bus& bus, const core::RobotModel& model, ControlOptions options);

  // Handles what arrived (waiting at most max_wait_ms) and publishes what is due.
  void Service(int max_wait_ms);

  const ServoBank& servos() const { return sequencer_.servos(); }
  const Sequencer& sequencer() const { return sequencer_; }
  // Set when the sim's ROBOT_MODEL is another robot than ours before this controller moved the
  // arm: sirupp-control exits 2 with it. Later, a mismatch is a fault (fault()).
  const std::string& start_refusal() const { return start_refusal_; }
  // The first cause of the present fault; empty when none. Cleared by COMMAND_CLEAR_FAULT.
  const std::string& fault() const { return sequencer_.fault(); }
  int64_t move_id() const { return sequencer_.move_id(); }
  int64_t states_answered() const { return states_answered_; }
  const std::string& last_error() const { return sequencer_.last_error(); }
  int8_t mode() const;   // controller_status_t::MODE_*
  int8_t state() const;  // controller_status_t::STATE_*
  // The plan loaded (running, paused or ended), or null.
  const Plan* plan() const { return sequencer_.plan(); }
  int plan_step() const { return sequencer_.plan_step(); }
  bool plan_running() const { return sequencer_.plan_running(); }

 private:
  void OnState(const sirupp::arm_state_t& message, const core::ReceiveInfo& info);
  void OnBoardStatus(const sirupp::board_status_t& message, const core::ReceiveInfo& info);
  // The answer to a state or board status (nullopt: the same tick again, sent again).
  void SendAnswer(const std::optional<core::ArmCommand>& command);
  void OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info);
  // ENVIRONMENT: the objects the sim has, which every plan is checked against before it runs.
  void OnEnvironment(const sirupp::environment_t& message, const core::ReceiveInfo& info);
  // Throws core::ConfigError at the plan's line when the plan's set-points pass through a static
  // object of the sim's environment or the arm itself (control/plan_collision.hpp).
  void CheckPlanInEnvironment(const Plan& plan, const std::vector<double>& start);
  void OnGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info);
  // A refusal of our latest ARM_MOVE on HARDWARE_REPLY stops the virtual arm too.
  void OnBridgeReply(const sirupp::command_reply_t& message, const core::ReceiveInfo& info);
  // Runs handle() (which hands a command to the sequencer), publishes what the sequencer asked
  // for, and answers the command on CONTROLLER_REPLY; `moves`: the command may start a move.
  template <class Msg, class Handle>
  void Answer(const Msg& message, const core::ReceiveInfo& info, bool moves, Handle&& handle);
  // `from_message`'s value of `message`; a refusal is also made the sequencer's last error.
  template <class Value, class Msg>
  Value Decoded(Value (*from_message)(const Msg&, const std::string&), const Msg& message,
                const std::string& channel);
  std::chrono::steady_clock::time_point Now() const { return options_.clock(); }
  void CheckSimAlive();
  void OnBridgeStatus(const sirupp::hardware_status_t& message);
  void CheckBridgeAlive();
  // Publishes what the sequencer asked for since the last call, in order.
  void Flush();
  void PublishMove(const MoveOrder& order);
  void PublishStatus(const StatusReport& report);
  // CONTROLLER_STATUS at 10 Hz and when the state changed.
  void PublishStatusIfDue();
  void PublishSetpoint(const core::ArmState& state, const std::vector<double>& effort);
  // CONTROLLER_GAINS: the live gains, 1 Hz and on change.
  void PublishGains(bool force);
  // The move and status a reply on CONTROLLER_REPLY names; `moves`: the command may start a move.
  core::ReplyFacts Facts(bool moves) const;

  core::Bus& bus_;
  core::RobotModel model_;
  ControlOptions options_;
  Sequencer sequencer_;
  core::Heartbeat heartbeat_;
  core::Replier replier_;                 // CONTROLLER_REPLY: one answer per command
  sirupp::arm_command_t last_command_{};  // sent again when the same tick's state comes again
  bool have_last_command_ = false;
  std::chrono::steady_clock::time_point last_state_wall_;
  std::chrono::steady_clock::time_point last_bridge_status_;
  bool bridge_linked_ = false;  // the newest HARDWARE_STATUS said LINKED
  bool bridge_lost_ = false;    // linked, then silent past bridge_timeout_s (until heard again)
  std::string start_refusal_;
  std::string model_checked_;  // source hash of the sim's model once it matched ours
  ModelSwitch model_switch_;   // a model announced on ARM_PLAN, until the sim publishes it
  std::optional<core::Environment> environment_;  // the sim's newest ENVIRONMENT
  std::chrono::steady_clock::time_point last_gains_;
  bool gains_changed_ = true;
  std::vector<servo::ChipGains> chip_gains_;  // the gains in force, as ARM_GAINS set them

  int64_t states_answered_ = 0;
  int64_t command_seq_ = 0;
  int64_t setpoint_seq_ = 0;
  int64_t move_seq_ = 0;
  int64_t last_move_utime_ = 0;  // of the latest ARM_MOVE, to match the bridge's reply
  int64_t status_seq_ = 0;
  int64_t gains_seq_ = 0;
  int8_t last_reported_state_ = -1;
  std::chrono::steady_clock::time_point last_status_;
};

}  // namespace sirupp::control
