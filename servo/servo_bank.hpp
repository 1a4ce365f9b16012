#pragma once
// One virtual PIC-SERVO per joint of an arm, in SI at its edges: moves in (rad or m, per joint),
// joint state in, joint efforts out, once per servo tick. What sirupp-sim runs beside the physics
// for the simulated arm's boards (sim/sim_node.hpp), and sirupp-control when it runs them itself
// (a student's controller, `--boards control`). The chip model itself is picservo.hpp.

#include <cstdint>
#include <vector>

#include "core/messages.hpp"
#include "core/robot_model.hpp"
#include "servo/picservo.hpp"
#include "servo/servo_units.hpp"

namespace sirupp::servo {

// servo_move_t::FLAG_ACTIVE (servo/ does not see the generated messages).
inline constexpr int8_t kMoveFlagActive = 1;

// One joint's part of a move (a LOAD_TRAJ): absolute goal, top speed and acceleration, SI.
struct JointMove {
  bool active = false;
  double goal = 0;          // rad or m
  double velocity = 0;      // rad/s or m/s, > 0
  double acceleration = 0;  // rad/s^2 or m/s^2, > 0
};

class ServoBank {
 public:
  // Gains from each joint's servo parameters (chip units); servos off until ServoOn.
  explicit ServoBank(const core::RobotModel& model);

  int num_joints() const { return static_cast<int>(servos_.size()); }
  // Every servo on at the arm's present positions.
  void ServoOn(const std::vector<double>& positions);
  // Loads the active joints' moves; throws std::invalid_argument naming the joint if a speed or
  // acceleration is not positive or a goal is not finite. Returns false if a servo was off.
  bool Load(const std::vector<JointMove>& moves);
  void StopSmooth();
  void MotorOff();
  void SetGains(int joint, const ServoGains& gains);
  // Another model of the same arm (same joint count): each joint's drive is rebuilt from it. A
  // joint whose encoder scale is unchanged keeps its servo as it is (set-point, integral, gains),
  // so the arm is held without a jolt; another one gets a new servo with the model's gains, on at
  // `positions` when `on`. Throws std::invalid_argument for another joint count.
  void ReplaceModel(const core::RobotModel& model, const std::vector<double>& positions, bool on);

  // One servo tick against the measured positions; returns the joint efforts (N*m or N).
  const std::vector<double>& Tick(const std::vector<double>& positions);

  bool AllDone() const;
  const PicServo& servo(int joint) const { return servos_[static_cast<size_t>(joint)]; }
  const JointDrive& drive(int joint) const { return drives_[static_cast<size_t>(joint)]; }
  // The profiled set-point of a joint, SI.
  double SetpointPosition(int joint) const;
  double SetpointVelocity(int joint) const;
  // The set-point's change of velocity over the last tick, per second (rad/s^2 or m/s^2).
  double SetpointAcceleration(int joint) const;
  // Where the joint's present move ends, SI.
  double Goal(int joint) const;
  // The chip's position error (command minus actual), SI.
  double PositionError(int joint) const;
  // The chip's status byte (servo::kMoveDone, kPositionError, ...).
  uint8_t Status(int joint) const;
  const ServoGains& Gains(int joint) const;
  // The first servo that tripped its position-error limit (0-based), or -1.
  int TrippedJoint() const;

 private:
  std::vector<JointDrive> drives_;
  std::vector<PicServo> servos_;
  std::vector<double> efforts_;
  std::vector<int64_t> previous_velocity_;  // profile velocity before the last tick, fixed point
};

// One servo_move_t command (ARM_MOVE's or SIM_BOARD_COMMAND's, decoded by
// core::ServoMoveFromMessage) applied to the boards, as a PIC-SERVO module takes LOAD_TRAJ,
// STOP_MOTOR or a servo-on: kMove loads the active joints (FLAG_RELATIVE and FLAG_VELOCITY_MODE are
// refused: sirupp-control sends neither); kStopSmooth decelerates every joint to rest; kStopAbrupt
// and kServoOn switch every servo on holding `positions` (the arm's present joints, SI); kMotorOff
// switches them off. Throws std::invalid_argument naming the joint and value when refused; the
// boards are then unchanged.
void ApplyMove(ServoBank& bank, const core::ServoMove& move, const std::vector<double>& positions);

}  // namespace sirupp::servo
