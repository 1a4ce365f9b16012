#include "servo/chip_gains.hpp"

#include <cmath>

#include "core/errors.hpp"
#include "core/translate.hpp"

namespace sirupp::servo {
namespace {

int Whole(double v) { return static_cast<int>(std::lround(v)); }

// One value of the message: a whole number in [low, high], else MessageError on field[j].
int Check(const std::string& channel, const core::RobotModel& model, const char* field, int j,
          double value, int low, int high, const char* why = nullptr) {
  if (std::isfinite(value) && value == std::floor(value) && value >= low && value <= high) {
    return static_cast<int>(value);
  }
  const core::Joint& joint = model.joints[static_cast<size_t>(j)];
  std::string allowed =
      low == high ? "allowed " + std::to_string(low)
                  : "allowed whole numbers " + std::to_string(low) + ".." + std::to_string(high);
  if (why) allowed = std::string(why) + "; " + allowed;
  throw core::MessageError(channel, std::string(field) + "[" + std::to_string(j) + "]",
                           core::FormatNumber(value) + " (joint j" + std::to_string(j + 1) + " " +
                               joint.name + "): " + allowed);
}

}  // namespace

ChipGains ChipGainsFromModel(const core::ServoParams& s) {
  ChipGains g;
  g.kp = Whole(s.kp);
  g.kd = Whole(s.kd);
  g.ki = Whole(s.ki);
  g.integration_limit = Whole(s.integration_limit);
  g.output_limit = Whole(s.output_limit);
  g.current_limit = Whole(s.current_limit);
  g.error_limit = Whole(s.error_limit);
  g.servo_rate_divisor = Whole(s.servo_rate_divisor);
  g.deadband = Whole(s.deadband);
  return g;
}

std::vector<ChipGains> ChipGainsFromModel(const core::RobotModel& model) {
  std::vector<ChipGains> gains;
  for (const core::Joint& joint : model.joints) gains.push_back(ChipGainsFromModel(joint.servo));
  return gains;
}

std::vector<ChipGains> ChipGainsFromMessage(const sirupp::servo_gains_t& m,
                                            const core::RobotModel& model,
                                            const std::string& channel) {
  const int n = model.num_joints();
  const auto size_ok = [n](const std::vector<double>& v) {
    return static_cast<int>(v.size()) == n;
  };
  if (m.num_joints != n || !size_ok(m.kp) || !size_ok(m.kd) || !size_ok(m.ki) ||
      !size_ok(m.integration_limit) || !size_ok(m.output_limit) || !size_ok(m.current_limit) ||
      !size_ok(m.error_limit) || !size_ok(m.servo_rate_divisor) || !size_ok(m.deadband)) {
    throw core::MessageError(channel, "num_joints",
                             std::to_string(m.num_joints) + " joints; the model " + model.name +
                                 " has " + std::to_string(n));
  }
  std::vector<ChipGains> gains(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    ChipGains& g = gains[i];
    g.kp = Check(channel, model, "kp", j, m.kp[i], 0, 32767);
    g.kd = Check(channel, model, "kd", j, m.kd[i], 0, 32767);
    g.ki = Check(channel, model, "ki", j, m.ki[i], 0, 32767);
    g.integration_limit =
        Check(channel, model, "integration_limit", j, m.integration_limit[i], 0, 32767);
    g.output_limit = Check(channel, model, "output_limit", j, m.output_limit[i], 0, 255);
    g.current_limit = Check(channel, model, "current_limit", j, m.current_limit[i], 0, 255);
    g.error_limit = Check(channel, model, "error_limit", j, m.error_limit[i], 0, 16383);
    g.servo_rate_divisor =
        Check(channel, model, "servo_rate_divisor", j, m.servo_rate_divisor[i], 1, 1,
              "the virtual servos run every tick, and the boards run the same law");
    g.deadband = Check(channel, model, "deadband", j, m.deadband[i], 0, 255);
  }
  return gains;
}

sirupp::servo_gains_t GainsMessage(const std::vector<ChipGains>& gains) {
  core::ServoGainsSet set;
  for (const ChipGains& g : gains) {
    set.joints.push_back(
        {static_cast<double>(g.kp), static_cast<double>(g.kd), static_cast<double>(g.ki),
         static_cast<double>(g.integration_limit), static_cast<double>(g.output_limit),
         static_cast<double>(g.current_limit), static_cast<double>(g.error_limit),
         static_cast<double>(g.servo_rate_divisor), static_cast<double>(g.deadband)});
  }
  return core::ToMessage(set);  // utime and seq 0: the caller stamps them
}

ServoGains ToServoGains(const ChipGains& g) {
  ServoGains s;
  s.kp = g.kp;
  s.kd = g.kd;
  s.ki = g.ki;
  s.integration_limit = g.integration_limit;
  s.output_limit = g.output_limit;
  s.error_limit = g.error_limit;
  s.deadband = g.deadband;
  return s;
}

}  // namespace sirupp::servo
