#pragma once
// One emulated PIC-SERVO SC module: the NMC command interpreter around the shared chip model
// (servo/picservo.hpp), as shared/reference/picservo.md describes the chip. It reads command
// packets (already split by nmc::PacketReader) and the motor's inputs each servo tick; it writes
// status replies and the PWM for its amplifier. No I/O and no clock: hardware/emulator.hpp puts N
// of these on a pseudo-terminal and runs the ticks. docs/hardware-emulator.md lists every choice
// made where the reference is silent.
//
// Addressing: after power-up or HARD_RESET the module has address 0, group 0xFF (no leader), and
// listens only if its ADDR_IN is enabled (the daisy chain: the previous module's ADDR_OUT, or
// always for the first module). Its first SET_ADDR lowers its ADDR_OUT (addr_out()), enabling the
// next module. A module whose ADDR_IN is disabled and that has no address hears only HARD_RESET
// to 0xFF.
//
// Replies: an individually addressed command always gets a reply (status byte, the DEF_STAT items,
// checksum), also after a bad checksum (CKSUM_ERROR set, the command not executed). A data length
// the command does not allow is treated the same way. Group commands: only the group leader
// replies. HARD_RESET and SET_BAUD never reply.

#include <cstdint>
#include <optional>
#include <vector>

#include "hardware/nmc_protocol.hpp"
#include "servo/picservo.hpp"

namespace sirupp::hardware {

// What the motor and its sensors give the module at a servo tick.
struct MotorInputs {
  int64_t encoder_counts = 0;  // the quadrature counter since power-up (before RESET_POS offsets)
  bool limit1 = false;         // LIMIT1 input level (1 = switch active)
  bool limit2 = false;
  bool index = false;  // encoder index input level
  // The index passed since the last tick, and the counter value at its edge (for homing on index,
  // which the chip captures in hardware rather than at a tick).
  bool index_crossed = false;
  int64_t index_edge_counts = 0;
  uint8_t current_ad = 0;  // CUR_SENSE A/D reading, 0..255, rising with current
  bool power_ok = true;    // motor supply in range (POWER_ON)
};

// The emulated EEPROM of the 1-byte HARD_RESET (SAVE_DATA).
struct ModuleEeprom {
  bool valid = false;
  uint8_t control = 0;  // the HARD_RESET byte: RESTORE_ADDR, EPU_AMP, EPU_SERVO, EPU_LIMITS, ...
  uint8_t address = 0;
  uint8_t group = 0xFF;
  bool leader = false;
  uint32_t velocity = 0;
  uint32_t acceleration = 0;
  nmc::Gains gains;
};

class PicServoModule {
 public:
  // The power-up state (address 0, group 0xFF, no items defined, servo and amplifier off, gains
  // all zero with SR 1 and SM 1, as JR Kerr's library assumes for a new module).
  PicServoModule();

  // What one command did.
  struct Result {
    bool heard = false;          // the packet was for this module (individually or its group)
    std::vector<uint8_t> reply;  // empty: no reply
    int new_baud = 0;            // SET_BAUD / HARD_RESET: the line speed after this command
  };
  // Handles one packet. `addr_in` is the module's ADDR_IN level (enabled by the chain).
  Result Handle(const nmc::Packet& packet, bool checksum_ok, bool addr_in);

  // One servo tick (0.512 ms): homing, limit stops, current check, profile and PID; returns the
  // PWM applied to the motor (0 while the amplifier is disabled), -255..255, positive = counts up.
  int Tick(const MotorInputs& inputs);

  // Command latency: a move (LOAD_TRAJ with START_NOW, or START_MOVE) takes effect this many servo
  // ticks after it arrives, as on a board whose host interface is slow to act; the reply is
  // immediate and MOVE_DONE reads clear while the move waits. 0 (power-up): at once. A later
  // move, a stop or a reset replaces a waiting one.
  void SetCommandLatencyTicks(int ticks) { latency_ticks_ = ticks < 0 ? 0 : ticks; }
  bool move_pending() const { return pending_.has_value(); }

  // Fault injection: an overcurrent trip, or a position-error trip, at the next tick.
  void TriggerOvercurrent() { inject_overcurrent_ = true; }
  void TriggerPositionErrorTrip() { inject_position_error_ = true; }

  // The ADDR_OUT level: true once the module has been given an address (enables the next module).
  bool addr_out() const { return addressed_; }
  uint8_t address() const { return address_; }
  uint8_t group() const { return group_; }
  bool leader() const { return leader_; }
  int pwm() const { return pwm_; }
  bool amp_enabled() const { return amp_enabled_; }
  int32_t position() const { return static_cast<int32_t>(position_); }
  // The status byte and auxiliary byte as a reply would carry them now.
  uint8_t status_byte() const;
  uint8_t aux_byte() const;
  nmc::Status StatusNow() const;
  const nmc::Gains& gains() const { return gains_; }
  const servo::PicServo& servo() const { return servo_; }
  size_t path_points() const { return path_.size(); }
  const ModuleEeprom& eeprom() const { return eeprom_; }

  // Path mode: each buffered point is one constant speed for one path period (no interpolation).
  static constexpr size_t kPathBufferSize = 128;

 private:
  enum class Addressing { kNone, kIndividual, kGroup };
  Addressing Match(uint8_t address, uint8_t command, bool addr_in) const;
  void Execute(const nmc::Packet& packet, Result* result, uint8_t* reply_items);
  void StartTrajectory(const nmc::Trajectory& t);
  void StopMotor(uint8_t control, int32_t here);
  void ApplyGains(const nmc::Gains& g);
  void ResetToPowerUp();
  void LimitStop(const MotorInputs& in);
  void PathTick();

  // Addressing.
  uint8_t address_ = 0;
  uint8_t group_ = nmc::kBroadcast;
  bool leader_ = false;
  bool addressed_ = false;
  // Status.
  uint8_t defined_items_ = 0;
  bool checksum_error_ = false;
  bool overcurrent_ = false;
  bool position_wrap_ = false;
  bool home_in_progress_ = false;
  uint8_t homing_control_ = 0;
  int64_t home_ = 0;
  uint8_t io_control_ = 0;
  bool amp_enabled_ = false;
  // Chip state.
  nmc::Gains gains_;
  servo::PicServo servo_;
  int servo_rate_count_ = 0;
  int64_t offset_ = 0;    // counter = encoder counts + offset (RESET_POS, SET_POS)
  int64_t position_ = 0;  // the counter at the last tick
  int64_t previous_position_ = 0;
  int velocity_ = 0;  // counts per tick, last tick
  int pwm_ = 0;
  MotorInputs last_inputs_;
  // LOAD_TRAJ: the values in force, and the buffer waiting for START_MOVE.
  uint32_t velocity_word_ = 0;
  uint32_t acceleration_word_ = 0;
  int32_t position_word_ = 0;
  uint8_t pwm_word_ = 0;
  std::optional<nmc::Trajectory> buffered_;
  // Path mode.
  std::vector<uint16_t> path_;
  bool path_mode_ = false;
  int path_ticks_left_ = 0;
  // Command latency: the move waiting, and the ticks until it starts.
  int latency_ticks_ = 0;
  std::optional<nmc::Trajectory> pending_;
  int pending_ticks_ = 0;
  void StartOrDefer(const nmc::Trajectory& t);
  // Fault injection.
  bool inject_overcurrent_ = false;
  bool inject_position_error_ = false;
  // EEPROM (kept across HARD_RESET).
  ModuleEeprom eeprom_;
};

}  // namespace sirupp::hardware
