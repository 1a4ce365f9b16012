#include "logger/samples.hpp"

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

GainsRecord GainsFromMessage(const sirupp::servo_gains_t& message) {
  GainsRecord gains;
  gains.utime = message.utime;
  gains.kp = message.kp;
  gains.kd = message.kd;
  gains.ki = message.ki;
  return gains;
}

}  // namespace sirupp::logger
