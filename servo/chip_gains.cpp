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
  if (value == std::floor(value) && value >= low && value <= high) return static_cast<int>(value);
  const core::Joint& joint = model.joints[static_cast<size_t>(j)];
  std::string allowed = low == high
                            ? std::to_string(low)
                            : "a whole number " + std::to_string(low) + ".." + std::to_string(high);
  if (why) allowed += " (" + std::string(why) + ")";
  core::RefuseValue(
      channel, std::string(field) + "[" + std::to_string(j) + "]",
      core::FormatNumber(value) + " (joint j" + std::to_string(j + 1) + " " + joint.name + ")",
      allowed);
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
  // Counts and finiteness first (core's pair), then the model's joints and the chip's ranges.
  const core::ServoGainsSet sent = core::ServoGainsFromMessage(m, channel);
  const int n = model.num_joints();
  core::CheckJointCount(channel, "num_joints", sent.joints.size(), n);
  std::vector<ChipGains> gains(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    const auto i = static_cast<size_t>(j);
    ChipGains& g = gains[i];
    const core::JointGains& v = sent.joints[i];
    g.kp = Check(channel, model, "kp", j, v.kp, 0, 32767);
    g.kd = Check(channel, model, "kd", j, v.kd, 0, 32767);
    g.ki = Check(channel, model, "ki", j, v.ki, 0, 32767);
    g.integration_limit =
        Check(channel, model, "integration_limit", j, v.integration_limit, 0, 32767);
    g.output_limit = Check(channel, model, "output_limit", j, v.output_limit, 0, 255);
    g.current_limit = Check(channel, model, "current_limit", j, v.current_limit, 0, 255);
    g.error_limit = Check(channel, model, "error_limit", j, v.error_limit, 0, 16383);
    g.servo_rate_divisor =
        Check(channel, model, "servo_rate_divisor", j, v.servo_rate_divisor, 1, 1,
              "the virtual servos run every tick, and the boards run the same law");
    g.deadband = Check(channel, model, "deadband", j, v.deadband, 0, 255);
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
