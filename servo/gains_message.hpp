#pragma once
// servo_gains_t (ARM_GAINS, CONTROLLER_GAINS, REAL_ARM_GAINS) to and from the chip's gains, in
// one place: the controller, the hardware bridge and the CLI read and write gains through these.

#include <cstdint>
#include <sirupp/servo_gains_t.hpp>
#include <string>
#include <vector>

#include "servo/picservo.hpp"

namespace sirupp::servo {

// One joint's gains as the message carries them: the filter gains and the settings the chip
// model does not use itself but a real board does (current limit, servo rate divisor).
struct JointGains {
  ServoGains filter;
  int current_limit = 0;       // CL, 0..255 (0 = off)
  int servo_rate_divisor = 1;  // SR, 1..255
};

// Every count field matches its array. Never fails.
sirupp::servo_gains_t GainsToMessage(const std::vector<JointGains>& gains, int64_t utime,
                                     int64_t seq);
sirupp::servo_gains_t GainsToMessage(const std::vector<ServoGains>& gains, int64_t utime,
                                     int64_t seq);

// Checks a received message: the joint count, whole numbers in the chip's ranges (kp, kd, ki,
// integration_limit 0..32767, output_limit, current_limit, deadband 0..255, error_limit 0..16383,
// servo_rate_divisor 1..255) and CheckGains. Throws core::MessageError naming the channel, the
// field with its joint index, the bad value and what is allowed.
std::vector<JointGains> GainsFromMessage(const sirupp::servo_gains_t& message,
                                         const std::string& channel, int num_joints);

}  // namespace sirupp::servo
