#pragma once
// The motors and the load behind the emulated PIC-SERVO modules: the whole arm at once, coupled by
// the model's rigid-body dynamics (core/dynamics.hpp), stepped at the servo tick. Reads each
// joint's PWM; writes joint angles and speeds, and the sensor levels a module reads (encoder
// counter since power-up, limit switches, encoder index, current-sense A/D). SI units, radians
// (metres for prismatic joints). Semi-implicit Euler with exact stick-slip by an active set:
// docs/hardware-emulator.md says how, and how it differs from sirupp-sim's ODE arm.
//
// Per joint j, per (sub)step of length h:
//   tau_motor = JointDrive::EffortFromPwm(pwm)         (PWM/255 * motor_torque_max * gear_ratio)
//   M(q) qdd = tau_motor + tau_ext - (C(q, qd) qd + G(q)) - viscous qd - friction
//   friction: sliding  (coulomb(dir) + (static - coulomb(dir)) exp(-(v / v_s)^2)) sign(v), with
//             static and Coulomb scaled by friction_scale; sticking joints are held (qdd = 0) while
//             the effort needed is within friction_scale * static, else released
//   qd += qdd h; a sliding joint whose speed reaches or crosses zero sticks; q += qd h
//   hard stops at the joint limits (inelastic)
//
// With ArmOptions::effects (a real-arm file, hardware/real_arm.hpp) the arm is a 1980s geared arm
// instead: the PWM sets the amplifier's voltage on a supply shared by all joints (which sags with
// the total current drawn), each motor's current follows its R-L circuit against the back-EMF, a
// compliant joint carries a rotor (armature) coupled to its link through a spring with backlash
// and the encoder sits on that rotor, friction is the file's per-direction levels, and the encoder
// reads whole multiples of a quantum. docs/hardware-emulator.md, "Real-arm effects".

#include <cstdint>
#include <optional>
#include <vector>

#include "core/dynamics.hpp"
#include "core/robot_model.hpp"
#include "hardware/picservo_module.hpp"
#include "hardware/real_arm.hpp"
#include "servo/servo_units.hpp"

namespace sirupp::hardware {

struct ArmOptions {
  // Static and Coulomb friction of the model times this (viscous unchanged). Above 1 by default,
  // so that the emulated "real" arm sticks more than the sim's, as the paper's robot did.
  double friction_scale = 1.5;
  // Physical joint positions at power-up (rad or m), one per joint; empty = all zero.
  std::vector<double> start_positions;
  // Integration substeps per servo tick (the PWM is held over them).
  int substeps = 2;
  // A limit switch is active within this distance of its joint limit (rad; metres for prismatic
  // joints use 1/100 of it).
  double limit_switch_margin_rad = 0.035;  // 2 degrees
  // CUR_SENSE A/D reading at |PWM| = 255 (proportional below).
  double current_ad_full_scale = 200;
  // Width of the encoder index pulse, in counts, once per motor revolution.
  int index_width_counts = 4;
  // Brakes: SetBrakes holds the chosen joints still whatever the effort (the PUMA's brakes, which
  // hold the arm while its amplifiers are off). Off: SetBrakes is ignored.
  bool brakes = true;
  // The real-arm effects (motor electrics, shared supply, gear train, per-direction friction,
  // encoder quantum). Unset: the model's rigid arm with friction x friction_scale, and the motor
  // torque proportional to the PWM. Set: friction_scale is not used. Checked by the constructor
  // (CheckRealArmParams).
  std::optional<RealArmParams> effects;
};

class EmulatedArm {
 public:
  // Throws std::invalid_argument on start positions of the wrong count, outside the joint limits,
  // or a bad option.
  EmulatedArm(const core::RobotModel& model, const ArmOptions& options);

  int num_joints() const { return static_cast<int>(position_.size()); }
  double tick_s() const { return tick_s_; }

  // One servo tick: `pwm` (one per joint, -255..255, missing entries 0) held for the tick.
  void Step(const std::vector<int>& pwm);
  // An extra effort on each joint (N*m or N), added to the motors' until changed (tests).
  void SetExternalEffort(const std::vector<double>& effort);
  // Which joints are braked (held still; missing entries: released). The emulator brakes every
  // joint whose module has its amplifier disabled.
  void SetBrakes(const std::vector<bool>& engaged);

  const std::vector<double>& positions() const { return position_; }
  const std::vector<double>& velocities() const { return velocity_; }
  bool sticking(int joint) const { return stuck_[static_cast<size_t>(joint)]; }
  double time_s() const { return time_s_; }
  // The joint effort of the motors at the last step (N*m or N).
  const std::vector<double>& motor_effort() const { return motor_effort_; }
  // With effects: each motor's current (A), the rotor angles at the joint (rad; the link's own
  // angle for a rigid joint) and the supply voltage now (V). Without: zeros, positions(), 0.
  const std::vector<double>& motor_current() const { return current_; }
  const std::vector<double>& rotor_positions() const { return rotor_position_; }
  double supply_voltage() const { return supply_v_; }
  // What the encoder of `joint` measures: the rotor's angle (rad or m) for a compliant joint, the
  // link's otherwise.
  double EncoderPosition(int joint) const;

  // What module `joint` reads at this tick: counter since power-up, switches, index, A/D.
  MotorInputs Inputs(int joint) const;
  const servo::JointDrive& drive(int joint) const { return drives_[static_cast<size_t>(joint)]; }

 private:
  void Substep(double h);
  void UpdateElectrics(double h);
  bool compliant(size_t j) const {
    return effects_ && effects_->joints[j].stiffness_nm_per_rad > 0;
  }
  // The gear train's torque on the link of compliant joint j (N*m).
  double TransmissionTorque(size_t j) const;
  int64_t AbsoluteCounts(int joint) const;

  core::RobotModel model_;
  std::optional<RealArmParams> effects_;
  core::Dynamics dynamics_;  // with the file's armature on rigid joints, none on compliant ones
  ArmOptions options_;
  double tick_s_;
  std::vector<servo::JointDrive> drives_;
  std::vector<double> position_, velocity_, motor_effort_, external_;
  std::vector<double> current_, rotor_position_, rotor_velocity_;
  double supply_v_ = 0;
  std::vector<bool> stuck_;
  std::vector<bool> braked_;
  std::vector<int> pwm_;
  std::vector<int64_t> power_up_counts_;  // absolute counts at power-up
  std::vector<int64_t> previous_counts_;  // absolute counts at the previous tick
  std::vector<int64_t> index_edge_;       // counter value at the last index edge
  std::vector<bool> index_crossed_;       // during the last tick
  double time_s_ = 0;
};

}  // namespace sirupp::hardware
