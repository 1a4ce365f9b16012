#pragma once
// The sirupp-control process logic over a core::Bus (first slice of issue 5): the virtual
// PIC-SERVOs answer every SIM_ARM_STATE with joint efforts on SIM_ARM_COMMAND (same tick, so
// sirupp-sim can run in lockstep), joint targets arrive on ARM_TARGET and go out as moves on
// ARM_MOVE, the servos' set-points on ARM_SETPOINT every tick, and CONTROLLER_STATUS at 10 Hz and
// on change.
//
// A target is refused whole, counted on ARM_TARGET and named in CONTROLLER_STATUS.last_error if it
// has the wrong joint count, a non-finite value, a position outside a joint's limits, or a negative
// speed or acceleration (0 = the joint's default from the model); nothing moves then. A target that
// arrives before the first arm state is kept and loaded when the servos come on.

#include <chrono>
#include <cstdint>
#include <memory>
#include <sirupp/arm_state_t.hpp>
#include <sirupp/joint_target_t.hpp>
#include <string>
#include <vector>

#include "control/effort_law.hpp"
#include "control/servo_bank.hpp"
#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/heartbeat.hpp"
#include "core/robot_model.hpp"

namespace sirupp::control {

struct ControlOptions {
  std::string name = "sirupp-control";  // arm_command_t.sender: the sim's participant name
  core::Channels channels;
  bool publish_setpoints = true;  // ARM_SETPOINT every tick
  // A student's controller in place of the PID filter; null = the PIC-SERVO PID (effort_law.hpp).
  std::shared_ptr<EffortLaw> effort_law;
};

class ControlNode {
 public:
  ControlNode(core::Bus& bus, const core::RobotModel& model, ControlOptions options);

  // Handles what arrived (waiting at most max_wait_ms) and publishes what is due.
  void Service(int max_wait_ms);

  const ServoBank& servos() const { return bank_; }
  int64_t move_id() const { return move_id_; }
  int64_t states_answered() const { return states_answered_; }
  const std::string& last_error() const { return last_error_; }

 private:
  void OnState(const sirupp::arm_state_t& message, const core::ReceiveInfo& info);
  void OnTarget(const sirupp::joint_target_t& message, const core::ReceiveInfo& info);
  void PublishStatus(bool force);
  // Efforts from the student's law for this tick; false (and last_error_ set) if it failed.
  bool StudentEfforts(const core::ArmState& state, std::vector<double>& effort);
  int8_t State() const;

  core::Bus& bus_;
  core::RobotModel model_;
  ControlOptions options_;
  ServoBank bank_;
  core::Heartbeat heartbeat_;
  bool servos_on_ = false;
  std::vector<JointMove> pending_;  // a target that arrived before the first arm state
  int64_t last_tick_ = -1;
  int64_t move_id_ = 0;
  int64_t states_answered_ = 0;
  int64_t command_seq_ = 0;
  int64_t setpoint_seq_ = 0;
  int64_t move_seq_ = 0;
  int64_t status_seq_ = 0;
  int64_t last_state_utime_ = 0;
  std::string last_error_;
  bool law_reset_ = false;
  bool law_failed_ = false;  // the student's law threw or returned a non-finite effort: arm held
  ControlInput law_input_;
  int8_t last_reported_state_ = -1;
  std::chrono::steady_clock::time_point last_status_;
};

}  // namespace sirupp::control
