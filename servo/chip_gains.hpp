#pragma once
// One set of gains for the virtual and the real arm: the nine SET_GAIN values of each joint in the
// chip's integer units, as ARM_GAINS (sirupp.servo_gains_t) and the model carry them, and the one
// rule that decides whether a gains message is accepted. sirupp-hardware applies it to ARM_GAINS
// before sending SET_GAIN to the boards; the controller can call the same function, so that a
// message is accepted by both or by neither (docs/hardware.md, "Gains").

#include <sirupp/servo_gains_t.hpp>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "servo/picservo.hpp"

namespace sirupp::servo {

struct ChipGains {
  int kp = 0;
  int kd = 0;
  int ki = 0;
  int integration_limit = 0;   // IL
  int output_limit = 0;        // OL, PWM 0..255
  int current_limit = 0;       // CL, 0..255 (0 or 255: no check)
  int error_limit = 0;         // EL, counts
  int servo_rate_divisor = 1;  // SR
  int deadband = 0;            // DB

  bool operator==(const ChipGains& o) const {
    return kp == o.kp && kd == o.kd && ki == o.ki && integration_limit == o.integration_limit &&
           output_limit == o.output_limit && current_limit == o.current_limit &&
           error_limit == o.error_limit && servo_rate_divisor == o.servo_rate_divisor &&
           deadband == o.deadband;
  }
  bool operator!=(const ChipGains& o) const { return !(*this == o); }
};

// The model's gains of one joint, rounded to the chip's integers.
ChipGains ChipGainsFromModel(const core::ServoParams& servo);
std::vector<ChipGains> ChipGainsFromModel(const core::RobotModel& model);

// The rule for a gains message on `channel` for `model`: the joint count must match, and every
// value be a whole number in its range: kp, kd, ki, integration_limit 0..32767; output_limit,
// current_limit, deadband 0..255; error_limit 0..16383; servo_rate_divisor 1 (the virtual servos
// run every tick, so the boards must too for one law). On the first bad value throws
// core::MessageError naming the channel, the field with its index, the joint, the value and the
// allowed range in core/translate.hpp's words, e.g. "channel ARM_GAINS: kp[1]: 40000 (joint j2
// shoulder) is not allowed; expected a whole number 0..32767"; counts and finiteness are
// core::ServoGainsFromMessage's. Nothing is returned then, so a receiver changes nothing.
std::vector<ChipGains> ChipGainsFromMessage(const sirupp::servo_gains_t& message,
                                            const core::RobotModel& model,
                                            const std::string& channel);

// The message carrying `gains` (utime and seq filled in by the caller).
sirupp::servo_gains_t GainsMessage(const std::vector<ChipGains>& gains);

// The part of ChipGains the chip model's PID uses.
ServoGains ToServoGains(const ChipGains& gains);

}  // namespace sirupp::servo
