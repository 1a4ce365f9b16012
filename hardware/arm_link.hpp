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

#include "core/messages.hpp"
#include "core/robot_model.hpp"
#include "hardware/bridge_settings.hpp"
#include "hardware/nmc_bus.hpp"
#include "servo/chip_gains.hpp"
#include "servo/servo_units.hpp"

namespace sirupp::hardware {

// The status items every poll asks for: position, auxiliary status, position error.
inline constexpr uint8_t kPollItems = nmc::kSendPosition | nmc::kSendAux | nmc::kSendPositionError;

// The calibration was refused: the arm cannot be shown to be in the calibration pose. what() says
// why and what is needed.
class CalibrationRefused : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What the bridge leaves in every module's home register once the module is calibrated (the
// counter set to it, SAVE_AS_HOME, the counter set back). A power cycle or HARD_RESET zeroes the
// register, so a module that still holds it has kept power, and its counter its calibration,
// since. ("SIRUPP calibrated", 0x51C0CA1B.)
inline constexpr int32_t kCalibrationMarker = 0x51C0CA1B;

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

// The gains a PIC-SERVO board's SET_GAIN carries, from the chip units servo::ChipGains holds: the
// one conversion, used by the bridge and by lab/'s in-process experiment.
nmc::Gains BoardGains(const servo::ChipGains& gains);

class ArmLink {
 public:
  ArmLink(const core::RobotModel& model, const BridgeSettings& settings, BytePort& port);

  // First, without a reset, asks the modules at the settings' baud whether they kept power since an
  // earlier bridge (they answer at their addresses). If every one does and holds the calibration
  // marker (and its counter a position within the joint's limits), the bridge resumes from their
  // counters: no reset, servos left as they are (armed() if all are on), calibrated() at once,
  // SET_GAIN (gains()) and DEF_STAT(kPollItems) only; connect_report() says so. Otherwise the
  // vendor start-up, then per module: amplifier off, SET_GAIN, CLEAR_BITS, DEF_STAT(kPollItems);
  // amplifiers stay disabled until Arm() (an arm with brakes holds). If modules had kept power
  // without a calibration, the reset zeroed their counters wherever the arm is: calibrating by the
  // pose is then refused (blind_reason()). Throws BusError, or std::runtime_error when the modules
  // found do not match the model (count or type).
  void Connect();
  // The calibration of BridgeSettings: joints without homing are defined to be at the calibration
  // pose's angle (RESET_POS with SET_POS); joints with homing search their switch or index at the
  // set speed and are defined from the latched home position. Every module then gets the
  // calibration marker. Servos end off. Requires Connect(). Throws CalibrationRefused, before
  // anything is sent, when a joint is to be defined by the pose but the arm cannot be shown to be
  // there: the boards had kept power without a calibration (blind_reason()), or the arm is
  // calibrated and its counters put a joint more than kPoseToleranceDeg from the pose.
  void Calibrate();
  static constexpr double kPoseToleranceDeg = 5;
  // Servos on, holding the present positions. Requires Calibrate().
  void Arm();
  // Smooth stop, then servos and amplifiers off.
  void Disarm();

  // "" if the move (as core::ServoMoveFromMessage decoded it) may be sent, else why not (limits,
  // speeds, joint count, state).
  std::string CheckMove(const core::ServoMove& move) const;
  // Sends a move checked by CheckMove.
  void Execute(const core::ServoMove& move);
  // A trapezoidal move of every joint to `goal` at default speeds (HOME). Checked first;
  // returns the refusal or "".
  std::string MoveAllTo(const std::vector<double>& goal);

  // The gains for every module from now on (they persist across connects and arming). Connected,
  // SET_GAIN goes to every module at once (in any state: the servos keep running on the new law);
  // board_gains() records what each module acknowledged. Throws BusError when a module does not
  // take them (its entry in board_gains() is then unknown). The values must have passed
  // servo::ChipGainsFromMessage's rule.
  void SetGains(const std::vector<servo::ChipGains>& gains);
  // Takes `model`, with `settings` (SettingsForModel's for it), in place of the present model: the
  // sim changed its model while the arm is not linked (BridgeNode). Refused, changing nothing
  // (std::runtime_error saying why), when the joint count or a joint's type differs, or while
  // calibrated when a joint's encoder scale (counts per rad or m) differs: the counters'
  // calibration would not hold. Gains never set by SetGains become the new model's, sent to the
  // modules at once when connected (BusError when a module does not take them).
  void ReplaceModel(const core::RobotModel& model, const BridgeSettings& settings);
  const core::RobotModel& model() const { return model_; }
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
  // The last Connect() resumed boards that kept power and their calibration (no reset).
  bool resumed() const { return resumed_; }
  // One line about the last Connect() when it was not the plain start-up (resumed, or boards that
  // had kept power without a calibration); else empty.
  const std::string& connect_report() const { return connect_report_; }
  // Why calibrating by the pose would be blind now; empty when it is not.
  const std::string& blind_reason() const { return blind_reason_; }
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
  // Why modules that answered at their addresses cannot be resumed from, or "".
  std::string ResumeProblem(const std::vector<NmcBus::Addressed>& kept) const;
  void Resume(const std::vector<NmcBus::Addressed>& kept);
  // Sets joint j's counter to `counts` and leaves the calibration marker in its home register.
  void SetCalibratedCounts(int j, int32_t counts);
  // The refusal's "what is needed" sentence.
  std::string CalibrationNeeds() const;
  void SendGains(int joint);
  // Joint j's goal in `move`: relative to its present goal with FLAG_RELATIVE.
  double Goal(int j, const core::JointMove& move) const;
  nmc::Trajectory TrajectoryFor(int j, double goal, double velocity, double acceleration,
                                bool velocity_mode) const;

  core::RobotModel model_;  // the sim's (ReplaceModel), at first the one given
  BridgeSettings settings_;
  NmcBus bus_;
  std::vector<servo::JointDrive> drives_;
  std::vector<servo::ChipGains> gains_;
  bool gains_set_ = false;  // by SetGains (ARM_GAINS); else the model's
  std::vector<std::optional<servo::ChipGains>> board_gains_;
  std::vector<double> goals_;
  std::vector<bool> velocity_mode_;
  std::vector<int32_t> last_counts_;
  std::chrono::steady_clock::time_point last_poll_{};
  bool have_last_poll_ = false;
  bool connected_ = false;
  bool calibrated_ = false;
  bool armed_ = false;
  bool resumed_ = false;
  // The boards were fresh (nobody answered at an address) at the last connect, and nothing has
  // driven the arm since: its counters still start where it was at power-up.
  bool fresh_and_undriven_ = false;
  std::string connect_report_;
  std::string blind_reason_;
};

}  // namespace sirupp::hardware
