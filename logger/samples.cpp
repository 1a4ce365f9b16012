#include "logger/samples.hpp"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "core/errors.hpp"

namespace sirupp::logger {

const char* StreamKey(Stream stream) {
  switch (stream) {
    case Stream::kSetpoint:
      return "set";
    case Stream::kVirtual:
      return "virt";
    case Stream::kReal:
      return "real";
  }
  return "?";
}

const char* StreamTitle(Stream stream) {
  switch (stream) {
    case Stream::kSetpoint:
      return "set-point";
    case Stream::kVirtual:
      return "virtual";
    case Stream::kReal:
      return "real";
  }
  return "?";
}

int64_t SequenceCounter::Next(int64_t seq) {
  int64_t missing = 0;
  if (have_ && seq > last_ + 1) missing = seq - last_ - 1;
  if (!have_ || seq != last_) last_ = seq;
  have_ = true;
  return missing;
}

}  // namespace sirupp::logger

namespace sirupp::logger {

Sample SampleFromArmState(const sirupp::arm_state_t& message, Stream stream, int64_t recv_utime) {
  Sample sample;
  sample.stream = stream;
  sample.source = message.source;
  sample.clock =
      message.source == sirupp::arm_state_t::SOURCE_SIM ? SampleClock::kSim : SampleClock::kWall;
  sample.utime = message.utime;
  sample.recv_utime = recv_utime;
  sample.position = message.position;
  sample.velocity = message.velocity;
  sample.effort = message.effort;
  return sample;
}

Sample SampleFromSetpoint(const sirupp::servo_setpoint_t& message, int64_t recv_utime) {
  Sample sample;
  sample.stream = Stream::kSetpoint;
  sample.clock = SampleClock::kSim;
  sample.utime = message.utime;
  sample.recv_utime = recv_utime;
  sample.move_id = message.move_id;
  sample.position = message.position;
  sample.velocity = message.velocity;
  sample.effort = message.effort;
  sample.done.reserve(message.status.size());
  for (int8_t bits : message.status) {
    sample.done.push_back((bits & sirupp::servo_setpoint_t::STATUS_MOVE_DONE) ? 1 : 0);
  }
  return sample;
}

PlanStatus StatusFromMessage(const sirupp::controller_status_t& message, int64_t recv_utime) {
  PlanStatus status;
  status.utime = message.utime;
  status.recv_utime = recv_utime;
  status.plan_name = message.plan_name;
  status.plan_step = message.plan_step;
  status.plan_steps = message.plan_steps;
  status.mode = message.mode;
  return status;
}

void ClockRate::Add(int64_t sim_utime, int64_t wall_utime) {
  if (!have_) {
    have_ = true;
    first_sim_ = sim_utime;
    first_wall_ = wall_utime;
  }
  last_sim_ = sim_utime;
  last_wall_ = wall_utime;
}

bool ClockRate::known() const { return have_ && last_wall_ - first_wall_ >= 100000; }

double ClockRate::factor() const {
  return known() ? static_cast<double>(last_sim_ - first_sim_) /
                       static_cast<double>(last_wall_ - first_wall_)
                 : std::numeric_limits<double>::quiet_NaN();
}

double ClockRate::sim_s() const { return have_ ? (last_sim_ - first_sim_) * 1e-6 : 0; }
double ClockRate::wall_s() const { return have_ ? (last_wall_ - first_wall_) * 1e-6 : 0; }

std::string ClockRate::Describe() const {
  if (!known()) return "not known yet";
  char text[96];
  std::snprintf(text, sizeof text, "%.5f (sim %.3f s over wall %.3f s)", factor(), sim_s(),
                wall_s());
  return text;
}

GainsRecord GainsFromMessage(const sirupp::servo_gains_t& message, GainsSource source,
                             int64_t recv_utime) {
  GainsRecord gains;
  gains.source = source;
  gains.utime = message.utime;
  gains.recv_utime = recv_utime;
  gains.kp = message.kp;
  gains.kd = message.kd;
  gains.ki = message.ki;
  gains.integration_limit = message.integration_limit;
  gains.output_limit = message.output_limit;
  gains.current_limit = message.current_limit;
  gains.error_limit = message.error_limit;
  gains.servo_rate_divisor = message.servo_rate_divisor;
  gains.deadband = message.deadband;
  return gains;
}

const char* GainsSourceTitle(GainsSource source) {
  switch (source) {
    case GainsSource::kRequest:
      return "requested";
    case GainsSource::kController:
      return "virtual servos";
    case GainsSource::kReal:
      return "real boards";
  }
  return "?";
}

const char* GainFieldName(int field) {
  static const char* const kNames[kNumGainFields] = {"kp",           "kd",
                                                     "ki",           "integration_limit",
                                                     "output_limit", "current_limit",
                                                     "error_limit",  "servo_rate_divisor",
                                                     "deadband"};
  return field >= 0 && field < kNumGainFields ? kNames[field] : "?";
}

const std::vector<double>& GainField(const GainsRecord& gains, int field) {
  switch (field) {
    case 0:
      return gains.kp;
    case 1:
      return gains.kd;
    case 2:
      return gains.ki;
    case 3:
      return gains.integration_limit;
    case 4:
      return gains.output_limit;
    case 5:
      return gains.current_limit;
    case 6:
      return gains.error_limit;
    case 7:
      return gains.servo_rate_divisor;
    default:
      return gains.deadband;
  }
}

std::string DescribeGainsChange(const GainsRecord& before, const GainsRecord& after) {
  std::string text;
  size_t joints = 0;
  for (int f = 0; f < kNumGainFields; ++f) joints = std::max(joints, GainField(after, f).size());
  for (size_t j = 0; j < joints; ++j) {
    std::string joint;
    for (int f = 0; f < kNumGainFields; ++f) {
      const std::vector<double>& old_values = GainField(before, f);
      const std::vector<double>& new_values = GainField(after, f);
      if (j >= new_values.size()) continue;
      const bool known = j < old_values.size();
      if (known && old_values[j] == new_values[j]) continue;
      joint += std::string(joint.empty() ? "" : ", ") + GainFieldName(f) + " " +
               (known ? core::FormatNumber(old_values[j]) : "?") + " -> " +
               core::FormatNumber(new_values[j]);
    }
    if (!joint.empty()) text += (text.empty() ? "j" : "; j") + std::to_string(j + 1) + " " + joint;
  }
  return text;
}

std::string DescribeGains(const GainsRecord& gains) {
  std::string text;
  for (int f = 0; f < kNumGainFields; ++f) {
    text += std::string(f ? "; " : "") + GainFieldName(f);
    for (double value : GainField(gains, f)) text += " " + core::FormatNumber(value);
  }
  return text;
}

}  // namespace sirupp::logger
