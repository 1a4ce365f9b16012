#pragma once
// What makes the emulated arm a 1980s geared arm rather than the model: the parameters of its
// physical effects, read from a real-arm file (config/hardware/puma260-real.yaml, format
// "sirupp-real-arm-1", docs/hardware-emulator.md "Real-arm effects"). Per joint: the DC motor and
// its amplifier (resistance, inductance, torque constant = back-EMF constant, current limit), the
// rotor's reflected inertia, the gear train (backlash, stiffness, damping), and the joint's
// friction per direction (static, Coulomb, viscous, Stribeck speed). For the arm: the power
// supply the six amplifiers share (open-circuit voltage, source resistance), the boards' command
// latency and the encoder's quantisation. Every number has a bounded, physically plausible range;
// a value outside it is a ConfigError naming file:line, the key path, the value and the range.
//
// SI inside (rad, rad/s, N*m, V, A, H, s); the file gives angles in degrees and inductances in mH.

#include <string>
#include <vector>

#include "core/robot_model.hpp"

namespace sirupp::hardware {

struct MotorParams {
  double resistance_ohm = 2.0;             // armature (winding + brushes)
  double inductance_h = 0.002;             // armature inductance
  double torque_constant_nm_per_a = 0.04;  // = back-EMF constant in V*s/rad (SI)
  double current_limit_a = 8.0;            // the amplifier's output current limit
};

struct JointEffects {
  MotorParams motor;
  double armature_kg_m2 = 0.01;     // rotor + gears, reflected to the joint (J_rotor * N^2)
  double backlash_rad = 0;          // total play of the gear train at the joint (0: none)
  double stiffness_nm_per_rad = 0;  // gear-train stiffness at the joint; 0: rigid
  double damping_nm_s_per_rad = 0;  // gear-train structural damping (while engaged)
  // Friction at the joint, per direction: [0] moving positive, [1] moving negative.
  double static_nm[2] = {1, 1};
  double coulomb_nm[2] = {0.8, 0.8};
  double viscous_nm_s_per_rad = 0.3;
  double stribeck_rad_s = 0.1;
};

struct RealArmParams {
  std::string source;  // the file (or "built-in")
  std::string description;
  std::string robot;                 // the model name it was made for
  double supply_voltage_v = 40;      // open-circuit voltage of the shared motor supply
  double supply_resistance_ohm = 0;  // its source resistance (sag = R * total current drawn)
  double command_latency_s = 0;      // a motion command takes effect this long after it arrives
  int encoder_quantum_counts = 1;    // the counter reads whole multiples of this
  std::vector<JointEffects> joints;  // one per model joint

  // Stall torque at the joint at full PWM with the supply unloaded (N*m): Kt * V / R * |gear|,
  // limited by the amplifier's current limit.
  double StallTorque(const core::RobotModel& model, int joint) const;
};

// The effects that reproduce the model itself: rigid joints, no backlash, the model's friction
// and armature, motors whose stall torque is motor_torque_max_nm with no back-EMF effect worth
// noting (a stiff supply and motors sized so). Used by tests as the base to change one effect.
RealArmParams ModelLikeParams(const core::RobotModel& model);

// Reads and validates a real-arm file for `model` (joint count and robot name must match).
// Throws core::ConfigError "FILE:LINE:COL: KEY: problem" for anything wrong.
RealArmParams LoadRealArmParams(const std::string& file, const core::RobotModel& model);
// Parses text (tests, error messages name `name`).
RealArmParams ParseRealArmParams(const std::string& text, const std::string& name,
                                 const core::RobotModel& model);
// The file text for `params` (comments carry `header`, one line each), which LoadRealArmParams
// reads back to the same values (to the 6 significant digits written).
std::string FormatRealArmParams(const RealArmParams& params, const std::string& header);

// Throws std::invalid_argument naming the joint and field if a value is outside its range (what the
// loader checks per field, for values set in code, e.g. by the fitting tool).
void CheckRealArmParams(const RealArmParams& params, const core::RobotModel& model);

// The ranges, for the fitter and the docs. Angles in SI.
struct ParamRange {
  double min, max;
};
namespace real_arm_range {
inline constexpr ParamRange kSupplyVoltage{12, 80};
inline constexpr ParamRange kSupplyResistance{0, 3};
inline constexpr ParamRange kCommandLatency{0, 0.3};
inline constexpr ParamRange kEncoderQuantum{1, 64};
inline constexpr ParamRange kResistance{0.3, 20};
inline constexpr ParamRange kInductance{0.00005, 0.02};
inline constexpr ParamRange kTorqueConstant{0.005, 0.2};
inline constexpr ParamRange kCurrentLimit{0.5, 30};
inline constexpr ParamRange kArmature{0.0001, 0.2};
inline constexpr ParamRange kBacklash{0, 0.035};      // 2 degrees
inline constexpr ParamRange kStiffness{200, 100000};  // or 0 for rigid
inline constexpr ParamRange kDamping{0, 50};
inline constexpr ParamRange kStatic{0, 8};
inline constexpr ParamRange kViscous{0, 5};
inline constexpr ParamRange kStribeck{0.005, 3.5};  // 0.3 .. 200 deg/s
}  // namespace real_arm_range

}  // namespace sirupp::hardware
