#include "servo/gains_message.hpp"

#include <cmath>
#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::servo {
namespace {

std::string Index(int j) { return "[" + std::to_string(j) + "]"; }

// A gain carried as a double: a whole number in [low, high], else MessageError on `field[j]`.
int WholeGain(const std::string& channel, const char* field, int j, double value, int low,
              int high) {
  if (!std::isfinite(value) || value != std::floor(value) || value < low || value > high) {
    throw core::MessageError(channel, field + Index(j),
                             core::FormatNumber(value) + ": allowed whole numbers " +
                                 std::to_string(low) + ".." + std::to_string(high));
  }
  return static_cast<int>(value);
}

}  // namespace

sirupp::servo_gains_t GainsToMessage(const std::vector<JointGains>& gains, int64_t utime,
                                     int64_t seq) {
  sirupp::servo_gains_t message{};
  message.utime = utime;
  message.seq = seq;
  message.num_joints = static_cast<int32_t>(gains.size());
  for (const JointGains& g : gains) {
    message.kp.push_back(g.filter.kp);
    message.kd.push_back(g.filter.kd);
    message.ki.push_back(g.filter.ki);
    message.integration_limit.push_back(g.filter.integration_limit);
    message.output_limit.push_back(g.filter.output_limit);
    message.current_limit.push_back(g.current_limit);
    message.error_limit.push_back(g.filter.error_limit);
    message.servo_rate_divisor.push_back(g.servo_rate_divisor);
    message.deadband.push_back(g.filter.deadband);
  }
  return message;
}

sirupp::servo_gains_t GainsToMessage(const std::vector<ServoGains>& gains, int64_t utime,
                                     int64_t seq) {
  std::vector<JointGains> joints;
  for (const ServoGains& g : gains) joints.push_back(JointGains{g, 0, 1});
  return GainsToMessage(joints, utime, seq);
}

std::vector<JointGains> GainsFromMessage(const sirupp::servo_gains_t& message,
                                         const std::string& channel, int num_joints) {
  if (message.num_joints != num_joints) {
    throw core::MessageError(channel, "num_joints",
                             std::to_string(message.num_joints) + " joints; the model has " +
                                 std::to_string(num_joints));
  }
  std::vector<JointGains> gains(static_cast<size_t>(num_joints));
  for (int j = 0; j < num_joints; ++j) {
    const auto i = static_cast<size_t>(j);
    JointGains& g = gains[i];
    g.filter.kp = WholeGain(channel, "kp", j, message.kp[i], 0, 32767);
    g.filter.kd = WholeGain(channel, "kd", j, message.kd[i], 0, 32767);
    g.filter.ki = WholeGain(channel, "ki", j, message.ki[i], 0, 32767);
    g.filter.integration_limit =
        WholeGain(channel, "integration_limit", j, message.integration_limit[i], 0, 32767);
    g.filter.output_limit = WholeGain(channel, "output_limit", j, message.output_limit[i], 0, 255);
    g.current_limit = WholeGain(channel, "current_limit", j, message.current_limit[i], 0, 255);
    g.filter.error_limit = WholeGain(channel, "error_limit", j, message.error_limit[i], 0, 16383);
    g.servo_rate_divisor =
        WholeGain(channel, "servo_rate_divisor", j, message.servo_rate_divisor[i], 1, 255);
    g.filter.deadband = WholeGain(channel, "deadband", j, message.deadband[i], 0, 255);
    try {
      CheckGains(g.filter);
    } catch (const std::invalid_argument& error) {
      throw core::MessageError(channel, "joint" + Index(j), error.what());
    }
  }
  return gains;
}

}  // namespace sirupp::servo
