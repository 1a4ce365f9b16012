#pragma once
// The virtual PIC-SERVO SC: one joint's trapezoidal profile generator and PID position filter,
// stepped once per servo tick (0.512 ms), in the chip's own units, so that the controller and the
// hardware emulator (hardware/picservo_module.hpp) run the same code. Units
// (shared/reference/picservo.md section 3):
//
//   position      encoder counts, kept in 16.16 fixed point (int64: counts * 65536)
//   velocity      counts per tick * 65536         (LOAD_TRAJ's 32-bit velocity word)
//   acceleration  counts per tick^2 * 65536       (LOAD_TRAJ's 32-bit acceleration word)
//   output        PWM, -output_limit..+output_limit (at most 255)
//
// Conversions to the virtual arm's SI values live in servo/servo_units.hpp and
// docs/servo-units.md.
//
// The PID arithmetic follows the model recommended in the reference, with the two scale factors
// the datasheet leaves open as named constants (kIntegralScale, kOutputShift):
//   e[k]   = command[k] - actual[k]                                  (whole counts)
//   I[k]   = clamp(I[k-1] + e[k], -IL * kIntegralScale, +IL * kIntegralScale)
//   u[k]   = Kp * e[k] + Kd * (e[k] - e[k-1]) + Ki * I[k] / kIntegralScale
//   pwm[k] = clamp(u[k] >> kOutputShift, -OL, +OL); nonzero pwm gets +DB in its own direction
//   |e[k]| > EL: servo off, POS_ERROR latched until the next servo-on.
//
// Beyond what sirupp-control uses (position moves, smooth and abrupt stops, motor off), the chip's
// other modes for the hardware emulator: velocity mode (LoadVelocity), open-loop PWM (SetPwm),
// STOP_HERE, RESET_POS / SET_POS (ResetPosition), and the bits the chip reports in its NMC status
// and auxiliary bytes (chip_flags(): POS_ERR latched until CLEAR_BITS and set whenever the servo is
// off, ACCEL_DONE and SLEW_DONE in the manual's wording).

#include <cstdint>

namespace sirupp::servo {

// SET_GAIN values, chip units (servo_gains_t carries the same numbers).
struct ServoGains {
  int kp = 100;
  int kd = 1000;
  int ki = 0;
  int integration_limit = 0;  // IL
  int output_limit = 255;     // OL, 0..255
  int error_limit = 4000;     // EL, counts
  int deadband = 0;           // DB, PWM units added to a nonzero output
};

// Throws std::invalid_argument naming the field, the value and the allowed range.
void CheckGains(const ServoGains& gains);

inline constexpr int64_t kFixedOne = 65536;  // 1.0 in 16.16 fixed point

// Whole counts to 16.16 fixed point, and back (rounding down, as the chip's integer part does).
constexpr int64_t ToFixed(int64_t counts) { return counts * kFixedOne; }
constexpr int64_t WholeCounts(int64_t fixed) {
  return fixed >= 0 ? fixed / kFixedOne : -((-fixed + kFixedOne - 1) / kFixedOne);
}

inline constexpr int kIntegralScale = 256;  // [UNVERIFIED on the chip] 1 or 256
inline constexpr int kOutputShift = 8;      // [UNVERIFIED on the chip] u / 256 = PWM
inline constexpr int kMaxPwm = 255;         // the PWM magnitude's full scale

// Status bits, as servo_setpoint_t::STATUS_*.
enum ServoStatus : uint8_t {
  kMoveDone = 1,
  kServoOn = 2,
  kPositionError = 4,
  kAccelerating = 8,
  kSlewing = 16,
  kDecelerating = 32,
  kSaturated = 64,
};

// The profile generator alone: where the command position goes, tick by tick. Two modes, as on
// the chip: position (a trapezoid to a goal; done() once at rest on it) and velocity (a ramp to a
// signed speed that is then kept; done() once the speed is reached, while the position moves on).
class TrapezoidalProfile {
 public:
  // Starts at rest at `position_fixed` (counts << 16).
  explicit TrapezoidalProfile(int64_t position_fixed = 0);

  // A new goal (counts << 16), top speed and acceleration (fixed point, > 0). Accepted mid-move:
  // the profile continues from its present command position and velocity. Throws
  // std::invalid_argument if velocity or acceleration is not positive.
  void SetGoal(int64_t goal_fixed, int64_t velocity_fixed, int64_t acceleration_fixed);
  // Velocity mode: ramp by `acceleration_fixed` (> 0) per tick from the present command velocity
  // to `velocity_fixed` (signed), then keep it. Throws std::invalid_argument if the acceleration
  // is not positive.
  void SetVelocity(int64_t velocity_fixed, int64_t acceleration_fixed);
  // STOP_SMOOTH: decelerate at the loaded acceleration to rest, wherever that is.
  void StopSmooth();
  // Rest at `position_fixed` at once (STOP_ABRUPT, servo-on, reset).
  void HoldAt(int64_t position_fixed);

  // Advances one tick; returns the new command position.
  int64_t Tick();

  int64_t position() const { return position_; }
  int64_t velocity() const { return velocity_; }
  int64_t goal() const { return goal_; }
  // Position mode: at rest on the goal. Velocity mode: the target speed is reached.
  bool done() const { return done_; }
  bool velocity_mode() const { return velocity_mode_; }
  // kAccelerating, kSlewing or kDecelerating for the last tick (0 when at rest). Speeding up is
  // accelerating, slowing down decelerating, whatever the sign of the velocity.
  uint8_t phase() const { return phase_; }

 private:
  int64_t position_;
  int64_t velocity_ = 0;
  int64_t goal_;
  int64_t max_velocity_ = 1;
  int64_t acceleration_ = 1;
  int64_t target_velocity_ = 0;  // velocity mode
  bool done_ = true;
  bool stopping_ = false;
  bool velocity_mode_ = false;
  uint8_t phase_ = 0;
};

// One joint's servo: profile + PID + the chip's status, stepped each tick with the encoder reading.
class PicServo {
 public:
  PicServo();

  void SetGains(const ServoGains& gains);
  const ServoGains& gains() const { return gains_; }

  // Servo on at the present actual position (clears status()'s position-error bit; the chip's
  // latched POS_ERR in chip_flags() stays until ClearLatches). Leaves PWM mode.
  void ServoOn(int64_t actual_counts);
  // LOAD_TRAJ in position mode: goal in counts, velocity and acceleration in fixed point. Ignored
  // (returns false) while the servo is off.
  bool LoadTrajectory(int64_t goal_counts, int64_t velocity_fixed, int64_t acceleration_fixed);
  // LOAD_TRAJ in velocity mode: ramp to `velocity_fixed` (signed) at `acceleration_fixed` (> 0);
  // MOVE_DONE once reached. Ignored (returns false) while the servo is off.
  bool LoadVelocity(int64_t velocity_fixed, int64_t acceleration_fixed);
  void StopSmooth();
  // Command position = actual position, at rest.
  void StopAbrupt(int64_t actual_counts);
  // STOP_HERE: the command position jumps to `position_counts`, at rest, no profile. Switches the
  // servo on first (at `actual_counts`) if it was off.
  void StopHere(int64_t position_counts, int64_t actual_counts);
  // Servo off: output 0 until the next ServoOn.
  void MotorOff();
  // Open-loop PWM mode (LOAD_TRAJ without ENABLE_SERVO): servo off, the output is `pwm` (clamped
  // to +-255; the output limit OL caps the servo only) until the next ServoOn or MotorOff.
  void SetPwm(int pwm);
  // RESET_POS and SET_POS: the encoder counter has just been set to `counts`; the command position
  // goes there too, at rest, so that an enabled servo does not jump.
  void ResetPosition(int64_t counts);
  // An injected position-error trip: as if |e| had exceeded EL this tick.
  void TripPositionError();
  // CLEAR_BITS: clears the latched POS_ERR (set again at the next tick while the servo is off).
  void ClearLatches();

  // One servo tick: advance the profile, run the PID against `actual_counts`; returns the PWM.
  int Tick(int64_t actual_counts);

  int output() const { return output_; }
  uint8_t status() const { return status_; }
  bool servo_on() const { return (status_ & kServoOn) != 0; }
  bool pwm_mode() const { return pwm_mode_; }
  int64_t position_error() const { return error_; }  // counts, last tick
  const TrapezoidalProfile& profile() const { return profile_; }

  // The bits the chip reports on the NMC bus (status byte and auxiliary byte).
  struct ChipFlags {
    bool move_done = true;        // MOVE_DONE: 1 at rest, at the target speed, or servo off
    bool position_error = false;  // POS_ERR: latched (EL exceeded, or the servo was off)
    bool servo_on = false;        // SERVO_ON (aux)
    bool accel_done = false;      // ACCEL_DONE (aux): set accelerating, clear decelerating
    bool slew_done = true;        // SLEW_DONE (aux): at constant speed or at rest
  };
  ChipFlags chip_flags() const;

 private:
  ServoGains gains_;
  TrapezoidalProfile profile_;
  int64_t error_ = 0;
  int64_t previous_error_ = 0;
  int64_t integral_ = 0;
  int output_ = 0;
  int pwm_ = 0;  // PWM mode's output
  bool pwm_mode_ = false;
  bool position_error_latched_ = true;  // the chip powers up with the servo off
  bool accel_done_ = false;
  uint8_t status_ = kMoveDone;
};

}  // namespace sirupp::servo
