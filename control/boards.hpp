#pragma once
// The virtual PIC-SERVO boards as the sequencer drives them, wherever they run:
//
//  - here (local): a ServoBank that the sequencer ticks with every state of the arm, what a
//    student's controller needs (it reads the profiles' set-points every tick) and what
//    `sirupp-control --boards control` keeps;
//  - in sirupp-sim (remote), beside the physics: every command becomes a servo_move_t for
//    SIM_BOARD_COMMAND (TakeCommands; numbered by seq), which the sim applies at the tick of this
//    controller's next answer, and the queries answer from the boards' status of the latest
//    exchange (TakeStatus, from SIM_BOARD_STATUS) and from the commands the boards have not
//    applied yet, as sirupp-hardware answers from its last poll of the real boards.
//
// Until the boards report a command applied (board_status_t.command_seq), a move it sent is not
// done (AllDone false), a servo-on it sent has cleared any trip (TrippedJoint -1) and Goal is the
// goal it sent: what a local bank would say at once.

#include <cstdint>
#include <vector>

#include "control/servo_bank.hpp"
#include "core/messages.hpp"
#include "core/robot_model.hpp"

namespace sirupp::control {

class Boards {
 public:
  Boards(const core::RobotModel& model, bool remote);

  bool remote() const { return remote_; }
  // The local bank (remote: it only keeps the gains in force).
  const ServoBank& local() const { return bank_; }
  int num_joints() const { return bank_.num_joints(); }

  // --- Commands (remote: queued for SIM_BOARD_COMMAND with the present move id).
  void set_move_id(int64_t move_id) { move_id_ = move_id; }
  void ServoOn(const std::vector<double>& positions);
  // Throws std::invalid_argument naming the joint, as ServoBank::Load.
  void Load(const std::vector<JointMove>& moves);
  void StopSmooth();
  void SetGains(int joint, const ServoGains& gains);
  void ReplaceModel(const core::RobotModel& model, const std::vector<double>& positions, bool on);
  // Local only: one servo tick; returns the efforts.
  const std::vector<double>& Tick(const std::vector<double>& positions);

  // --- Remote: out and in.
  std::vector<core::ServoMove> TakeCommands();
  // The boards at an exchange (board_status_t.boards) and the last command they applied.
  void TakeStatus(const core::ServoSetpoint& boards, int64_t command_seq);

  // --- Queries, SI.
  bool AllDone() const;
  double SetpointPosition(int joint) const;
  double SetpointVelocity(int joint) const;
  double SetpointAcceleration(int joint) const;  // remote: 0 (no per-tick profile here)
  double Goal(int joint) const;
  double PositionError(int joint) const;
  uint8_t Status(int joint) const;
  const ServoGains& Gains(int joint) const { return bank_.Gains(joint); }
  int TrippedJoint() const;

 private:
  void Send(core::MoveCommand command, const std::vector<double>& goals,
            const std::vector<JointMove>* moves);
  bool Pending() const { return sent_seq_ >= 0 && applied_seq_ != sent_seq_; }
  const core::JointSetpoint& Reported(int joint) const;

  ServoBank bank_;
  bool remote_;
  int64_t move_id_ = 0;
  std::vector<core::ServoMove> out_;
  int64_t sent_seq_ = -1;     // seq of the last command sent
  int64_t applied_seq_ = -1;  // ... and of the last one the boards applied
  core::ServoSetpoint status_;
  // Since the last command the boards applied: a move or smooth stop sent (not done until they
  // report), a servo-on sent (no trip), the goals sent (NaN: none).
  bool pending_motion_ = false;
  bool pending_servo_on_ = false;
  std::vector<double> pending_goal_;
};

}  // namespace sirupp::control
