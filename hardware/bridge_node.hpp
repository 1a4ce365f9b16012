#pragma once
// The sirupp-hardware process logic over a core::Bus: the real arm (ArmLink) on the bus, and the
// safety layer.
//
// In:  HARDWARE_COMMAND (connect, calibrate, arm, disarm, link, unlink, home, clear faults),
//      ARM_MOVE (mirrored to the boards while linked), ARM_GAINS (SET_GAIN to every module while
//      connected, kept for later), ESTOP, and the controller's liveness (CONTROLLER_STATUS, sent
//      at 10 Hz, and ARM_MOVE) for command expiry.
// Out: REAL_ARM_STATE and REAL_ARM_SETPOINT every poll (poll_rate_hz), HARDWARE_STATUS (10 Hz and
//      on every change), REAL_ARM_GAINS (what the modules acknowledged; 1 Hz and on every
//      change, while connected), HARDWARE_REPLY (one answer per HARDWARE_COMMAND, ARM_MOVE and
//      ARM_GAINS, naming the request), HEARTBEAT.
//
// Safety (each threshold a setting, docs/hardware.md):
//  - nothing moves unless connected, calibrated and armed; ARM_MOVE only while linked;
//  - start guard: HARDWARE_COMMAND and ARM_MOVE are refused for start_guard_s after start-up;
//  - moves outside the soft joint limits or above the velocity / acceleration caps are refused
//    whole, before a byte is sent; velocity-mode joints are stopped at the soft limits;
//  - linked and moving with nothing from the controller for command_timeout_s: smooth stop;
//  - ESTOP: abrupt stop, servos off, amplifiers disabled; moves refused until released and
//  re-armed;
//  - a module that fails every retry, or reports POS_ERR / OVERCURRENT while armed, is a FAULT:
//    every joint stops smoothly and stays stopped until CLEAR_FAULTS and ARM;
//  - Shutdown() (SIGINT, SIGTERM, fatal error): stop, servos off, amplifiers disabled.
// Every refusal is counted as rejected on its channel and named in last_error.

#include <chrono>
#include <cstdint>
#include <optional>
#include <sirupp/controller_status_t.hpp>
#include <sirupp/estop_t.hpp>
#include <sirupp/hardware_command_t.hpp>
#include <sirupp/hardware_status_t.hpp>
#include <sirupp/robot_model_t.hpp>
#include <sirupp/servo_gains_t.hpp>
#include <sirupp/servo_move_t.hpp>
#include <sirupp/servo_setpoint_t.hpp>
#include <string>

#include "core/bus.hpp"
#include "core/channels.hpp"
#include "core/command_reply.hpp"
#include "core/heartbeat.hpp"
#include "core/model_check.hpp"
#include "core/robot_model.hpp"
#include "hardware/arm_link.hpp"

namespace sirupp::hardware {

struct BridgeOptions {
  std::string name = "sirupp-hardware";
  core::Channels channels;
};

class BridgeNode {
 public:
  using Clock = std::chrono::steady_clock;

  // `link` must outlive the node. Subscribes at once; the start guard runs from here.
  BridgeNode(core::Bus& bus, const core::RobotModel& model, ArmLink& link, BridgeSettings settings,
             BridgeOptions options = {});

  // The operator's own start-up steps (command-line flags), not subject to the start guard.
  // Each throws what ArmLink throws.
  void Connect();
  void Calibrate();
  void Arm();
  void Link();

  // Handles messages for up to max_wait_ms, then polls and publishes if a cycle is due.
  void Service(int max_wait_ms);
  // Before exit: stops the arm, servos off, amplifiers disabled; publishes the final status.
  void Shutdown();

  int8_t state() const;  // hardware_status_t::STATE_*
  bool linked() const { return linked_; }
  bool estopped() const { return estopped_; }
  const std::string& last_error() const { return last_error_; }
  const ArmReading& reading() const { return reading_; }
  int64_t polls() const { return polls_; }
  int64_t moves_mirrored() const { return moves_mirrored_; }

 private:
  // The status a reply on HARDWARE_REPLY names.
  core::ReplyFacts Facts() const;
  // "model NAME hash HASH": the start of the heartbeat's detail when all is well.
  std::string ModelDetail() const;
  void OnCommand(const sirupp::hardware_command_t& message, const core::ReceiveInfo& info);
  // One HARDWARE_COMMAND action (`what` names it and its sender in refusals).
  void Do(core::HardwareAction action, const std::string& what, const std::string& channel);
  // `from_message`'s value of `message` (core/translate.hpp); a refusal is also the status's
  // last_error.
  template <class Value, class Msg>
  Value Decoded(Value (*from_message)(const Msg&, const std::string&), const Msg& message,
                const std::string& channel);
  void OnMove(const sirupp::servo_move_t& message, const core::ReceiveInfo& info);
  void OnEstop(const sirupp::estop_t& message, const core::ReceiveInfo& info);
  void OnGains(const sirupp::servo_gains_t& message, const core::ReceiveInfo& info);
  // ROBOT_MODEL: linked, another model is a fault; not linked, the bridge takes the sim's model
  // (ArmLink::ReplaceModel) or, when it cannot, keeps its own and refuses to arm or link.
  void OnModel(const sirupp::robot_model_t& message, const core::ReceiveInfo& info);
  void NoteController() { last_controller_ = Clock::now(); }

  // Refuses (counts on `channel`, last_error, throws MessageError) while the start guard runs.
  void CheckStartGuard(const std::string& channel);
  // Seconds until the start guard ends (<= 0 once it has).
  double StartGuardLeft() const;
  [[noreturn]] void Refuse(const std::string& channel, const std::string& problem);
  void Fault(const std::string& problem);
  void Cycle();
  void CheckSafety();
  void PublishState();
  void PublishStatus();
  // REAL_ARM_GAINS, when every module's gains are known.
  void PublishGains();

  core::Bus& bus_;
  core::RobotModel model_;  // the sim's once taken (OnModel), at first the one given
  ArmLink& link_;
  BridgeSettings settings_;
  BridgeOptions options_;
  std::optional<core::ModelWatch> model_watch_;  // the sim's ROBOT_MODEL against ours: one robot
  core::Heartbeat heartbeat_;
  core::Replier replier_;  // HARDWARE_REPLY: one answer per HARDWARE_COMMAND, ARM_MOVE, ARM_GAINS

  Clock::time_point started_;
  Clock::time_point next_cycle_;
  Clock::time_point last_status_{};
  Clock::time_point last_gains_{};
  Clock::time_point last_controller_{};
  bool linked_ = false;
  bool estopped_ = false;
  bool faulted_ = false;
  bool expired_ = false;  // commands expired during the present motion (reported once)
  std::string last_error_;
  std::string fault_;  // the first problem of the present fault
  ArmReading reading_;
  int64_t move_id_ = -1;
  int64_t polls_ = 0;
  int64_t state_commands_ = 0;  // hardware commands and stops handled, to spot stale readings
  int64_t moves_mirrored_ = 0;
  int64_t state_seq_ = 0;
  int64_t setpoint_seq_ = 0;
  int64_t status_seq_ = 0;
  int64_t gains_seq_ = 0;
  int8_t last_published_state_ = -1;
  int64_t first_poll_us_ = 0;
};

}  // namespace sirupp::hardware
