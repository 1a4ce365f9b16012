#pragma once
// The real arm as the bridge sees it, without LCM: one PIC-SERVO SC per joint on an NMC bus.
// Start-up as the vendor library does it, calibration, arming, loading moves (every joint's
// LOAD_TRAJ, then one START_MOVE to the group so they start together), polling the modules, and
// the stops the safety layer needs. SI at its edges; the chip's units inside (servo/servo_units).
// bridge_node.hpp puts it on the bus. docs/hardware.md.

#include <chrono>
#include <cstdint>
#include <optional>
#include <sirupp/servo_move_t.hpp>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "hardware/bridge_settings.hpp"
#include "hardware/nmc_bus.hpp"
#include "servo/chip_gains.hpp"
#include "servo/servo_units.hpp"

namespace sirupp::hardware {

// The status items every poll asks for: position, auxiliary status, position error.
inline constexpr uint8_t kPollItems = nmc::kSendPosition | nmc::kSendAux | nmc::kSendPositionError;

// One poll of every module.
struct ArmReading {
  int64_t wall_us = 0;                  // the middle of the poll, microseconds since the epoch
  std::vector<bool> answered;           // false: the module failed every try (see errors)
  std::vector<std::string> errors;      // per joint, empty when it answered
  std::vector<uint8_t> status;          // raw status byte
  std::vector<uint8_t> aux;             // raw auxiliary status byte
  std::vector<int32_t> counts;          // encoder position
  std::vector<int32_t> position_error;  // command - actual, counts
  std::vector<double> position;         // rad or m
  std::vector<double> velocity;         // from the change of position since the previous poll
  std::vector<double> setpoint;         // the chip's command position: position + error
  std::vector<double> effort;           // estimated from the error through Kp (see docs)
};

class ArmLink {
 public:
  ArmLink(const core::RobotModel& model, const BridgeSettings& settings, BytePort& port);

  // Vendor start-up, then per module: amplifier off, SET_GAIN (gains()), CLEAR_BITS,
  // DEF_STAT(kPollItems). Amplifiers stay disabled until Arm() (an arm with brakes holds). Throws
  // BusError, or std::runtime_error when the modules found do not match the model (count or type).
  void Connect();
  // The calibration of BridgeSettings: joints without homing are defined to be at the calibration
  // pose's angle (RESET_POS with SET_POS); joints with homing search their switch or index at the
  // set speed and are defined from the latched home position. Servos end off. Requires Connect().
  void Calibrate();
  // Servos on, holding the present positions. Requires Calibrate().
  void Arm();
  // Smooth stop, then servos and amplifiers off.
  void Disarm();

  // "" if the move may be sent, else why not (limits, speeds, joint count, state).
  std::string CheckMove(const sirupp::servo_move_t& move) const;
  // Sends a move checked by CheckMove.
  void Execute(const sirupp::servo_move_t& move);
  // A trapezoidal move of every joint to `goal` at default speeds (HOME). Checked first;
  // returns the refusal or "".
  std::string MoveAllTo(const std::vector<double>& goal);

  // The gains for every module from now on (they persist across connects and arming). Connected,
  // SET_GAIN goes to every module at once (in any state: the servos keep running on the new law);
  // board_gains() records what each module acknowledged. Throws BusError when a module does not
  // take them (its entry in board_gains() is then unknown). The values must have passed
  // servo::ChipGainsFromMessage's rule.
  void SetGains(const std::vector<servo::ChipGains>& gains);
  // The gains sent to the modules (from the model until SetGains).
  const std::vector<servo::ChipGains>& gains() const { return gains_; }
  // Per module, the gains it acknowledged (its SET_GAIN reply came without CKSUM_ERROR) since the
  // last reset; nullopt while unknown (not connected, or a SET_GAIN failed). The chip cannot be
  // asked for its gains (no status item or command reads them back), so this is what the bridge
  // knows the boards hold.
  const std::vector<std::optional<servo::ChipGains>>& board_gains() const { return board_gains_; }

  // One exchange per module. A module that fails every try is marked in the reading; the others
  // are still read.
  ArmReading Poll();

  // Stops every joint smoothly (one broadcast packet: works even when a module is silent).
  void StopAllSmoothly();
  // ESTOP: every joint stops abruptly, then servos off and amplifiers disabled (broadcast).
  void EmergencyStop();
  // Clears latched bits (POS_ERR, OVERCURRENT, ...) on every module that answers; servos stay off.
  void ClearFaults();
  // Before exit: abrupt stop, servos off, amplifiers disabled, then hard reset (modules back to
  // their power-up baud, as the vendor library leaves them). Never throws.
  void Shutdown();

  bool connected() const { return connected_; }
  bool calibrated() const { return calibrated_; }
  bool armed() const { return armed_; }
  // Joints loaded in velocity mode by the last move (watched against the soft limits).
  const std::vector<bool>& velocity_mode() const { return velocity_mode_; }
  const std::vector<double>& goals() const { return goals_; }
  const servo::JointDrive& drive(int j) const { return drives_[static_cast<size_t>(j)]; }
  NmcBus& bus() { return bus_; }
  int num_joints() const { return static_cast<int>(drives_.size()); }
  static uint8_t Address(int joint) { return static_cast<uint8_t>(joint + 1); }

 private:
  void Home(int joint, const JointHoming& homing);
  void SendGains(int joint);
  nmc::Trajectory TrajectoryFor(int j, double goal, double velocity, double acceleration,
                                bool velocity_mode) const;

  const core::RobotModel& model_;
  BridgeSettings settings_;
  NmcBus bus_;
  std::vector<servo::JointDrive> drives_;
  std::vector<servo::ChipGains> gains_;
  std::vector<std::optional<servo::ChipGains>> board_gains_;
  std::vector<double> goals_;
  std::vector<bool> velocity_mode_;
  std::vector<int32_t> last_counts_;
  std::chrono::steady_clock::time_point last_poll_{};
  bool have_last_poll_ = false;
  bool connected_ = false;
  bool calibrated_ = false;
  bool armed_ = false;
};

}  // namespace sirupp::hardware
