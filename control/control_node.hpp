#pragma once
// The sirupp-control process logic over a core::Bus: the sequencer and the virtual PIC-SERVOs.
//
// In:  SIM_ARM_STATE (answered on SIM_ARM_COMMAND with the same tick, so sirupp-sim can run in
//      lockstep), ARM_TARGET (joint targets), ARM_POSE_TARGET (tool targets through IK), ARM_PLAN
//      (movement plans: run, pause, resume, abort; manual/automatic mode), ARM_GAINS (live gains).
// Out: ARM_MOVE (every move and stop, as LOAD_TRAJ), ARM_SETPOINT (every tick), CONTROLLER_STATUS
//      (10 Hz and on every change), CONTROLLER_REPLY (one answer per ARM_TARGET, ARM_POSE_TARGET,
//      ARM_PLAN and ARM_GAINS, naming the request), HEARTBEAT.
//
// Modes: MANUAL takes targets; a plan run switches to AUTOMATIC until the plan ends or is aborted.
// COMMAND_AUTOMATIC also locks out targets with no plan running (until COMMAND_MANUAL), so a
// class's plan cannot be disturbed. Anything refused (bad values, unreachable pose, bad plan, a
// target in automatic mode) is counted as rejected on its channel and named in last_error; nothing
// moves then. ESTOP stops the arm at once where it is (STOP_ABRUPT on ARM_MOVE), aborts a plan
// and refuses targets and plan runs until released. A servo that trips its position-error limit
// aborts the plan; the next accepted target or plan switches the servos on again where the arm is.

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <sirupp/arm_command_t.hpp>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/command_reply_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <sirupp/plan_command_t.hpp>
#include <sirupp/pose_target_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <string>
#include <vector>

#include "control/effort_law.hpp"
#include "control/plan.hpp"
#include "control/servo_bank.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/command_reply.hpp"
#include "core/errors.hpp"
#include "core/heartbeat.hpp"
#include "core/motion_limits.hpp"
#include "core/robot_model.hpp"
#include "servo/chip_gains.hpp"

namespace sirupp::control {

struct ControlOptions {
  std::string name = "sirupp-control";  // arm_command_t.sender: the sim's participant name
  core::Channels channels;
  bool publish_setpoints = true;  // ARM_SETPOINT every tick
  // A student's controller in place of the PID filter; null = the PIC-SERVO PID (effort_law.hpp).
  std::shared_ptr<EffortLaw> effort_law;
  // No SIM_ARM_STATE for this long (wall clock) = the sim is lost: a plan is aborted, the real
  // arm stopped (STOP_SMOOTH on ARM_MOVE), the status says so until states come again.
  double sim_timeout_s = 0.5;
};

class ControlNode {
 public:
  ControlNode(core::Bus& bus, const core::RobotModel& model, ControlOptions options);

  // Handles what arrived (waiting at most max_wait_ms) and publishes what is due.
  void Service(int max_wait_ms);

  const ServoBank& servos() const { return bank_; }
  // Set when the sim's ROBOT_MODEL is another robot than ours before this controller moved the
  // arm: sirupp-control exits 2 with it. Later, a mismatch is a fault (fault()).
  const std::string& start_refusal() const { return start_refusal_; }
  // The first cause of the present fault; empty when none. Cleared by COMMAND_CLEAR_FAULT.
  const std::string& fault() const { return fault_; }
  int64_t move_id() const { return move_id_; }
  int64_t states_answered() const { return states_answered_; }
  const std::string& last_error() const { return last_error_; }
  int8_t mode() const;   // controller_status_t::MODE_*
  int8_t state() const;  // controller_status_t::STATE_*
  // The plan loaded (running, paused or ended), or null.
  const Plan* plan() const { return plan_ ? &*plan_ : nullptr; }
  int plan_step() const { return plan_step_; }
  bool plan_running() const { return plan_running_; }

 private:
  void OnState(const sirupp::arm_state_t& message, const core::ReceiveInfo& info);
  void OnTarget(const sirupp::joint_target_t& message, const core::ReceiveInfo& info);
  void OnPoseTarget(const sirupp::pose_target_t& message, const core::ReceiveInfo& info);
  void OnPlan(const sirupp::plan_command_t& message, const core::ReceiveInfo& info);
  void OnGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info);
  void OnEstop(const sirupp::estop_t& message, const core::ReceiveInfo& info);
  void OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info);
  // A fault: the arm is braked (HOLD), the set-points stop, a plan is aborted; the first cause
  // is kept (later ones are consequences) until COMMAND_CLEAR_FAULT.
  void Fault(const std::string& cause);
  void ClearFault();
  // Throws MessageError on `channel` while a fault is latched.
  void RequireNoFault(const std::string& channel, const std::string& what) const;
  // A state with a smaller tick than the last: a new sim run. Aborts a plan, takes the new state.
  void OnSimRestart(int64_t from_tick, int64_t to_tick);
  void CheckSimAlive();
  // Throws MessageError on `channel` if a move breaks the motion limits the bridge applies.
  void CheckMotionLimits(const std::string& channel, const std::vector<JointMove>& moves) const;
  // A refusal of our latest ARM_MOVE on HARDWARE_REPLY stops the virtual arm too.
  void OnBridgeReply(const sirupp::command_reply_t& reply);
  // CONTROLLER_GAINS: the live gains, 1 Hz and on change.
  void PublishGains(bool force);
  // Throws MessageError on `channel` while the emergency stop is engaged.
  void RequireNoEstop(const std::string& channel, const std::string& what) const;

  // Throws MessageError on `channel` if targets are not taken now (automatic mode, no arm yet).
  void RequireManual(const std::string& channel) const;
  // Loads the moves into the servos (switching them on again after a fault) and publishes them.
  void StartMove(const std::vector<JointMove>& moves);
  // A stop (servo_move_t::COMMAND_STOP_*) for every joint, at its present set-point.
  void PublishStop(int8_t command);
  void PublishMove(int8_t command, const std::vector<JointMove>& moves);
  // Throws MessageError on `channel` unless the message has the model's joint count.
  void CheckJointCount(const std::string& channel, int32_t num_joints) const;
  // Runs plan steps due at sim time `utime` (called once per tick before the servos tick).
  void AdvancePlan(int64_t utime);
  void EndPlan(const std::string& error);
  // `cause` ends a running plan ("...; plan NAME aborted"), or is the last error when none runs.
  void AbortPlanOrReport(const std::string& cause);
  // Records a refusal: last_error, a status at once; the caller throws to count it.
  void Refuse(const core::MessageError& error);
  void PublishSetpoint(const core::ArmState& state, const std::vector<double>& effort);
  void PublishStatus(bool force);
  // The move and status a reply on CONTROLLER_REPLY names; `moves`: the command may start a move.
  core::ReplyFacts Facts(bool moves) const;
  // Efforts from the student's law for this tick; false (and last_error_ set) if it failed.
  bool StudentEfforts(const core::ArmState& state, std::vector<double>& effort);
  // The servo that tripped its position-error limit (0-based), or -1.
  int TrippedJoint() const;

  core::Bus& bus_;
  core::RobotModel model_;
  ControlOptions options_;
  ServoBank bank_;
  core::Heartbeat heartbeat_;
  core::Replier replier_;  // CONTROLLER_REPLY: one answer per command
  bool servos_on_ = false;
  std::vector<JointMove> pending_;  // a target that arrived before the first arm state
  std::vector<double> positions_;   // the last measured joint positions
  int64_t last_tick_ = -1;
  int64_t last_state_utime_ = 0;
  sirupp::arm_command_t last_command_{};  // sent again when the same tick's state comes again
  bool have_last_command_ = false;
  std::chrono::steady_clock::time_point last_state_wall_;
  bool sim_lost_ = false;
  std::string fault_;
  std::string start_refusal_;
  std::string model_checked_;  // source hash of the sim's model once it matched ours
  std::chrono::steady_clock::time_point last_gains_;
  bool gains_changed_ = true;
  int64_t gains_seq_ = 0;
  std::vector<servo::ChipGains> chip_gains_;  // the gains in force, as ARM_GAINS set them
  core::MotionLimits motion_limits_;          // the bridge's rule (core/motion_limits.hpp)

  // Sequencer.
  std::string estop_;              // who engaged the emergency stop and why; empty when released
  bool locked_automatic_ = false;  // COMMAND_AUTOMATIC given (until COMMAND_MANUAL)
  std::optional<Plan> plan_;
  bool plan_running_ = false;  // from RUN until its last move is done, an abort or a fault
  int plan_step_ = 0;          // next step to run; == steps.size() when the plan has ended
  bool plan_paused_ = false;
  int64_t wait_until_utime_ = -1;  // end of the present `wait SECONDS`, -1 when none
  int64_t paused_at_utime_ = 0;
  bool trip_reported_ = false;

  int64_t move_id_ = 0;
  int64_t states_answered_ = 0;
  int64_t command_seq_ = 0;
  int64_t setpoint_seq_ = 0;
  int64_t move_seq_ = 0;
  int64_t last_move_utime_ = 0;  // of the latest ARM_MOVE, to match the bridge's reply
  int64_t status_seq_ = 0;
  std::string last_error_;
  bool law_reset_ = false;
  bool law_failed_ = false;  // the student's law threw or returned a non-finite effort: arm held
  ControlInput law_input_;
  int8_t last_reported_state_ = -1;
  std::chrono::steady_clock::time_point last_status_;
};

}  // namespace sirupp::control
