// Translation pairs for the servo, command, status, heartbeat, reply and image messages (the
// model, arm state and arm command pairs are in translate.cpp). Every FromMessage checks in the
// same order: counts against arrays, then each field in message order; the first problem is thrown.

#include <cmath>

#include "core/errors.hpp"
#include "core/message_helpers.hpp"
#include "core/translate.hpp"

namespace sirupp::core {

namespace {

using detail::GetQuaternion;
using detail::GetVector;
using detail::PutQuaternion;
using detail::PutVector;

// A field's name for an error text ("position[3]"), built only when a value is refused. The checks
// run on every message, 1953 a second on each per-tick channel; building every name each time was
// a tenth of sirupp-logger's CPU. Holds a pointer: use it within the expression that made it.
class Field {
 public:
  Field(const char* name) : name_(name) {}                 // NOLINT(google-explicit-constructor)
  Field(const std::string& name) : name_(name.c_str()) {}  // NOLINT(google-explicit-constructor)
  Field(const char* name, size_t index) : name_(name), index_(index), indexed_(true) {}
  Field(const std::string& name, size_t index) : Field(name.c_str(), index) {}
  std::string str() const {
    return indexed_ ? std::string(name_) + "[" + std::to_string(index_) + "]" : std::string(name_);
  }

 private:
  const char* name_;
  size_t index_ = 0;
  bool indexed_ = false;
};

[[noreturn]] void Refuse(const std::string& channel, const std::string& field,
                         const std::string& value, const std::string& allowed) {
  RefuseValue(channel, field, value, allowed);
}

// A count field and one of the arrays it counts.
template <class T>
void CheckArray(const std::string& channel, const char* count_field, int32_t count,
                const Field& array_field, const std::vector<T>& array) {
  if (count < 0) Refuse(channel, count_field, std::to_string(count), "a count >= 0");
  if (array.size() != static_cast<size_t>(count)) {
    throw MessageError(channel, array_field.str(),
                       std::to_string(array.size()) + " entries sent; " + count_field + " says " +
                           std::to_string(count));
  }
}

double Finite(const std::string& channel, const Field& field, double value) {
  if (!std::isfinite(value)) Refuse(channel, field.str(), FormatNumber(value), "a finite number");
  return value;
}

double NonNegative(const std::string& channel, const Field& field, double value) {
  if (!(std::isfinite(value) && value >= 0)) {
    Refuse(channel, field.str(), FormatNumber(value), "a finite number >= 0");
  }
  return value;
}

int64_t NonNegativeCount(const std::string& channel, const Field& field, int64_t value) {
  if (value < 0) Refuse(channel, field.str(), std::to_string(value), "a count >= 0");
  return value;
}

bool Flag(const std::string& channel, const Field& field, int8_t value) {
  if (value != 0 && value != 1) Refuse(channel, field.str(), std::to_string(value), "0 or 1");
  return value == 1;
}

// An enum field: `value` in 0..last, `names` lists them for the error text.
template <class Enum>
Enum EnumValue(const std::string& channel, const Field& field, int8_t value, int last,
               const char* names) {
  if (value < 0 || value > last) {
    Refuse(channel, field.str(), std::to_string(value),
           "0.." + std::to_string(last) + " (" + names + ")");
  }
  return static_cast<Enum>(value);
}

// A bit set field: only the bits below 2^bits may be set.
int8_t Bits(const std::string& channel, const Field& field, int8_t value, int bits,
            const char* names) {
  if (value < 0 || value >= (1 << bits)) {
    Refuse(channel, field.str(), std::to_string(value),
           "a sum of " + std::string(names) + " bits, 0.." + std::to_string((1 << bits) - 1));
  }
  return value;
}

int8_t I8(bool value) { return value ? 1 : 0; }
template <class Enum>
int8_t I8(Enum value) {
  return static_cast<int8_t>(value);
}
int32_t Count(size_t size) { return static_cast<int32_t>(size); }

}  // namespace

// ---- servo_setpoint_t

sirupp::servo_setpoint_t ToMessage(const ServoSetpoint& setpoint) {
  sirupp::servo_setpoint_t m{};
  m.utime = setpoint.utime;
  m.seq = setpoint.seq;
  m.tick = setpoint.tick;
  m.move_id = setpoint.move_id;
  m.num_joints = Count(setpoint.joints.size());
  for (const JointSetpoint& j : setpoint.joints) {
    m.position.push_back(j.position);
    m.velocity.push_back(j.velocity);
    m.goal.push_back(j.goal);
    m.position_error.push_back(j.position_error);
    m.effort.push_back(j.effort);
    m.status.push_back(j.status);
  }
  return m;
}

ServoSetpoint ServoSetpointFromMessage(const sirupp::servo_setpoint_t& m,
                                       const std::string& channel) {
  CheckArray(channel, "num_joints", m.num_joints, "position", m.position);
  CheckArray(channel, "num_joints", m.num_joints, "velocity", m.velocity);
  CheckArray(channel, "num_joints", m.num_joints, "goal", m.goal);
  CheckArray(channel, "num_joints", m.num_joints, "position_error", m.position_error);
  CheckArray(channel, "num_joints", m.num_joints, "effort", m.effort);
  CheckArray(channel, "num_joints", m.num_joints, "status", m.status);
  ServoSetpoint setpoint;
  setpoint.utime = m.utime;
  setpoint.seq = m.seq;
  setpoint.tick = m.tick;
  setpoint.move_id = m.move_id;
  for (size_t i = 0; i < m.position.size(); ++i) {
    JointSetpoint j;
    j.position = Finite(channel, Field("position", i), m.position[i]);
    j.velocity = Finite(channel, Field("velocity", i), m.velocity[i]);
    j.goal = Finite(channel, Field("goal", i), m.goal[i]);
    j.position_error = Finite(channel, Field("position_error", i), m.position_error[i]);
    j.effort = Finite(channel, Field("effort", i), m.effort[i]);
    j.status = Bits(channel, Field("status", i), m.status[i], 7, "STATUS_*");
    setpoint.joints.push_back(j);
  }
  return setpoint;
}

// ---- arm_ticks_t

sirupp::arm_ticks_t ToMessage(const ArmTicks& ticks) {
  sirupp::arm_ticks_t m{};
  m.sent_utime = ticks.sent_utime;
  m.seq = ticks.seq;
  m.num_states = static_cast<int32_t>(ticks.states.size());
  for (const TickedState& state : ticks.states) {
    m.states.push_back(ToMessage(state.state, state.seq));
    m.state_utime.push_back(state.made_utime);
  }
  m.num_setpoints = static_cast<int32_t>(ticks.setpoints.size());
  for (const TickedSetpoint& setpoint : ticks.setpoints) {
    m.setpoints.push_back(ToMessage(setpoint.setpoint));
    m.setpoint_utime.push_back(setpoint.made_utime);
  }
  return m;
}

ArmTicks ArmTicksFromMessage(const sirupp::arm_ticks_t& m, const std::string& channel,
                             int expected_joints) {
  CheckCount(channel, "num_states", m.num_states, m.states);
  CheckCount(channel, "num_states", m.num_states, m.state_utime);
  CheckCount(channel, "num_setpoints", m.num_setpoints, m.setpoints);
  CheckCount(channel, "num_setpoints", m.num_setpoints, m.setpoint_utime);
  ArmTicks ticks;
  ticks.sent_utime = m.sent_utime;
  ticks.seq = m.seq;
  int joints = expected_joints;
  for (size_t k = 0; k < m.states.size(); ++k) {
    const std::string place = channel + " states[" + std::to_string(k) + "]";
    TickedState state{ArmStateFromMessage(m.states[k], place, joints), m.states[k].seq,
                      m.state_utime[k]};
    joints = state.state.num_joints();
    if (!ticks.states.empty() && state.state.tick < ticks.states.back().state.tick) {
      throw MessageError(channel, "states[" + std::to_string(k) + "].tick",
                         std::to_string(state.state.tick) + " comes before the tick before it (" +
                             std::to_string(ticks.states.back().state.tick) +
                             "): allowed in tick order");
    }
    ticks.states.push_back(std::move(state));
  }
  for (size_t k = 0; k < m.setpoints.size(); ++k) {
    const std::string place = channel + " setpoints[" + std::to_string(k) + "]";
    TickedSetpoint setpoint{ServoSetpointFromMessage(m.setpoints[k], place), m.setpoint_utime[k]};
    if (joints >= 0) {
      CheckJointCount(place, "num_joints", setpoint.setpoint.joints.size(), joints);
    }
    ticks.setpoints.push_back(std::move(setpoint));
  }
  return ticks;
}

// ---- board_status_t

sirupp::board_status_t ToMessage(const BoardStatus& status) {
  sirupp::board_status_t m{};
  m.utime = status.utime;
  m.seq = status.seq;
  m.tick = status.tick;
  m.next_tick = status.next_tick;
  m.command_seq = status.command_seq;
  m.arm = ToMessage(status.arm, status.seq);
  m.boards = ToMessage(status.boards);
  return m;
}

BoardStatus BoardStatusFromMessage(const sirupp::board_status_t& m, const std::string& channel,
                                   int expected_joints) {
  BoardStatus status;
  status.utime = m.utime;
  status.seq = m.seq;
  status.tick = m.tick;
  status.next_tick = m.next_tick;
  status.command_seq = m.command_seq;
  status.arm = ArmStateFromMessage(m.arm, channel, expected_joints);
  status.boards = ServoSetpointFromMessage(m.boards, channel);
  CheckJointCount(channel, "boards.num_joints", status.boards.joints.size(),
                  status.arm.num_joints());
  if (status.arm.tick != status.tick) {
    throw MessageError(channel, "arm.tick",
                       std::to_string(status.arm.tick) + " is not the exchange tick " +
                           std::to_string(status.tick));
  }
  if (status.next_tick <= status.tick) {
    throw MessageError(
        channel, "next_tick",
        std::to_string(status.next_tick) + ": allowed after tick " + std::to_string(status.tick));
  }
  if (status.command_seq < -1) {
    throw MessageError(channel, "command_seq",
                       std::to_string(status.command_seq) + ": allowed -1 (none) or more");
  }
  return status;
}

// ---- servo_move_t

sirupp::servo_move_t ToMessage(const ServoMove& move) {
  sirupp::servo_move_t m{};
  m.utime = move.utime;
  m.seq = move.seq;
  m.move_id = move.move_id;
  m.command = I8(move.command);
  m.num_joints = Count(move.joints.size());
  for (const JointMove& j : move.joints) {
    m.goal.push_back(j.goal);
    m.max_velocity.push_back(j.max_velocity);
    m.acceleration.push_back(j.acceleration);
    m.flags.push_back(j.flags);
  }
  return m;
}

ServoMove ServoMoveFromMessage(const sirupp::servo_move_t& m, const std::string& channel) {
  CheckArray(channel, "num_joints", m.num_joints, "goal", m.goal);
  CheckArray(channel, "num_joints", m.num_joints, "max_velocity", m.max_velocity);
  CheckArray(channel, "num_joints", m.num_joints, "acceleration", m.acceleration);
  CheckArray(channel, "num_joints", m.num_joints, "flags", m.flags);
  ServoMove move;
  move.utime = m.utime;
  move.seq = m.seq;
  move.move_id = m.move_id;
  move.command = EnumValue<MoveCommand>(channel, "command", m.command, 4, "COMMAND_*");
  for (size_t i = 0; i < m.goal.size(); ++i) {
    JointMove j;
    j.goal = Finite(channel, Field("goal", i), m.goal[i]);
    j.max_velocity = NonNegative(channel, Field("max_velocity", i), m.max_velocity[i]);
    j.acceleration = NonNegative(channel, Field("acceleration", i), m.acceleration[i]);
    j.flags = Bits(channel, Field("flags", i), m.flags[i], 3, "FLAG_*");
    move.joints.push_back(j);
  }
  return move;
}

// ---- servo_gains_t

sirupp::servo_gains_t ToMessage(const ServoGainsSet& gains) {
  sirupp::servo_gains_t m{};
  m.utime = gains.utime;
  m.seq = gains.seq;
  m.num_joints = Count(gains.joints.size());
  for (const JointGains& g : gains.joints) {
    m.kp.push_back(g.kp);
    m.kd.push_back(g.kd);
    m.ki.push_back(g.ki);
    m.integration_limit.push_back(g.integration_limit);
    m.output_limit.push_back(g.output_limit);
    m.current_limit.push_back(g.current_limit);
    m.error_limit.push_back(g.error_limit);
    m.servo_rate_divisor.push_back(g.servo_rate_divisor);
    m.deadband.push_back(g.deadband);
  }
  return m;
}

ServoGainsSet ServoGainsFromMessage(const sirupp::servo_gains_t& m, const std::string& channel) {
  const std::pair<const char*, const std::vector<double>*> arrays[] = {
      {"kp", &m.kp},
      {"kd", &m.kd},
      {"ki", &m.ki},
      {"integration_limit", &m.integration_limit},
      {"output_limit", &m.output_limit},
      {"current_limit", &m.current_limit},
      {"error_limit", &m.error_limit},
      {"servo_rate_divisor", &m.servo_rate_divisor},
      {"deadband", &m.deadband}};
  for (const auto& [field, array] : arrays) {
    CheckArray(channel, "num_joints", m.num_joints, field, *array);
  }
  ServoGainsSet gains;
  gains.utime = m.utime;
  gains.seq = m.seq;
  for (size_t i = 0; i < m.kp.size(); ++i) {
    for (const auto& [field, array] : arrays) Finite(channel, Field(field, i), (*array)[i]);
    gains.joints.push_back(JointGains{m.kp[i], m.kd[i], m.ki[i], m.integration_limit[i],
                                      m.output_limit[i], m.current_limit[i], m.error_limit[i],
                                      m.servo_rate_divisor[i], m.deadband[i]});
  }
  return gains;
}

// ---- joint_target_t

sirupp::joint_target_t ToMessage(const JointTarget& target) {
  sirupp::joint_target_t m{};
  m.utime = target.utime;
  m.seq = target.seq;
  m.num_joints = Count(target.joints.size());
  for (const JointGoal& j : target.joints) {
    m.position.push_back(j.position);
    m.max_velocity.push_back(j.max_velocity);
    m.acceleration.push_back(j.acceleration);
    m.active.push_back(I8(j.active));
  }
  return m;
}

JointTarget JointTargetFromMessage(const sirupp::joint_target_t& m, const std::string& channel) {
  CheckArray(channel, "num_joints", m.num_joints, "position", m.position);
  CheckArray(channel, "num_joints", m.num_joints, "max_velocity", m.max_velocity);
  CheckArray(channel, "num_joints", m.num_joints, "acceleration", m.acceleration);
  CheckArray(channel, "num_joints", m.num_joints, "active", m.active);
  JointTarget target;
  target.utime = m.utime;
  target.seq = m.seq;
  for (size_t i = 0; i < m.position.size(); ++i) {
    JointGoal j;
    j.active = Flag(channel, Field("active", i), m.active[i]);
    j.position = Finite(channel, Field("position", i), m.position[i]);
    j.max_velocity = NonNegative(channel, Field("max_velocity", i), m.max_velocity[i]);
    j.acceleration = NonNegative(channel, Field("acceleration", i), m.acceleration[i]);
    target.joints.push_back(j);
  }
  return target;
}

// ---- pose_target_t

sirupp::pose_target_t ToMessage(const PoseTarget& target) {
  sirupp::pose_target_t m{};
  m.utime = target.utime;
  m.seq = target.seq;
  PutVector(target.position, m.position);
  PutQuaternion(target.orientation, m.orientation);
  m.position_only = I8(target.position_only);
  m.shoulder = I8(target.shoulder);
  m.elbow = I8(target.elbow);
  m.wrist = I8(target.wrist);
  m.speed_scale = target.speed_scale;
  return m;
}

PoseTarget PoseTargetFromMessage(const sirupp::pose_target_t& m, const std::string& channel) {
  PoseTarget target;
  target.utime = m.utime;
  target.seq = m.seq;
  for (size_t i = 0; i < 3; ++i) Finite(channel, Field("position", i), m.position[i]);
  target.position = GetVector(m.position);
  target.position_only = Flag(channel, "position_only", m.position_only);
  target.orientation = GetQuaternion(m.orientation);
  const double norm = target.orientation.norm();
  if (!target.position_only && !(std::abs(norm - 1) <= 1e-3)) {
    Refuse(channel, "orientation", "quaternion norm " + FormatNumber(norm),
           "a unit quaternion (w, x, y, z), norm 1 +- 0.001");
  }
  target.shoulder = EnumValue<ArmChoice>(channel, "shoulder", m.shoulder, 2,
                                         "SHOULDER_ANY, SHOULDER_LEFT, SHOULDER_RIGHT");
  target.elbow =
      EnumValue<ArmChoice>(channel, "elbow", m.elbow, 2, "ELBOW_ANY, ELBOW_UP, ELBOW_DOWN");
  target.wrist =
      EnumValue<ArmChoice>(channel, "wrist", m.wrist, 2, "WRIST_ANY, WRIST_NO_FLIP, WRIST_FLIP");
  if (!(m.speed_scale == 0 || (m.speed_scale > 0 && m.speed_scale <= 1))) {
    Refuse(channel, "speed_scale", FormatNumber(m.speed_scale), "(0, 1], or 0 for 1");
  }
  target.speed_scale = m.speed_scale;
  return target;
}

// ---- plan_command_t

sirupp::plan_command_t ToMessage(const PlanCommand& command) {
  sirupp::plan_command_t m{};
  m.utime = command.utime;
  m.seq = command.seq;
  m.command = I8(command.command);
  m.name = command.name;
  m.text = command.text;
  return m;
}

PlanCommand PlanCommandFromMessage(const sirupp::plan_command_t& m, const std::string& channel) {
  PlanCommand command;
  command.utime = m.utime;
  command.seq = m.seq;
  command.command = EnumValue<PlanAction>(channel, "command", m.command, 7, "COMMAND_*");
  command.name = m.name;
  command.text = m.text;
  return command;
}

// ---- hardware_command_t

sirupp::hardware_command_t ToMessage(const HardwareCommand& command) {
  sirupp::hardware_command_t m{};
  m.utime = command.utime;
  m.seq = command.seq;
  m.command = I8(command.command);
  m.sender = command.sender;
  return m;
}

HardwareCommand HardwareCommandFromMessage(const sirupp::hardware_command_t& m,
                                           const std::string& channel) {
  HardwareCommand command;
  command.utime = m.utime;
  command.seq = m.seq;
  command.command = EnumValue<HardwareAction>(channel, "command", m.command, 7, "COMMAND_*");
  command.sender = m.sender;
  return command;
}

// ---- estop_t

sirupp::estop_t ToMessage(const EStop& estop) {
  sirupp::estop_t m{};
  m.utime = estop.utime;
  m.seq = estop.seq;
  m.engaged = I8(estop.engaged);
  m.sender = estop.sender;
  m.reason = estop.reason;
  return m;
}

EStop EStopFromMessage(const sirupp::estop_t& m, const std::string& channel) {
  EStop estop;
  estop.utime = m.utime;
  estop.seq = m.seq;
  if (m.engaged != 0 && m.engaged != 1) {
    Refuse(channel, "engaged", std::to_string(m.engaged), "0 (release) or 1 (engage)");
  }
  estop.engaged = m.engaged == 1;
  estop.sender = m.sender;
  estop.reason = m.reason;
  return estop;
}

// ---- sim_command_t

sirupp::sim_command_t ToMessage(const SimCommand& command) {
  sirupp::sim_command_t m{};
  m.utime = command.utime;
  m.seq = command.seq;
  m.sender = command.sender;
  m.command = command.action == SimAction::kLoadModel
                  ? sirupp::sim_command_t::COMMAND_LOAD_MODEL
                  : sirupp::sim_command_t::COMMAND_LOAD_ENVIRONMENT;
  m.name = command.name;
  m.text = command.text;
  return m;
}

SimCommand SimCommandFromMessage(const sirupp::sim_command_t& m, const std::string& channel) {
  SimCommand command;
  command.utime = m.utime;
  command.seq = m.seq;
  command.sender = m.sender;
  if (m.command == sirupp::sim_command_t::COMMAND_LOAD_MODEL) {
    command.action = SimAction::kLoadModel;
  } else if (m.command != sirupp::sim_command_t::COMMAND_LOAD_ENVIRONMENT) {
    Refuse(channel, "command", std::to_string(m.command), "0 (load environment) or 1 (load model)");
  }
  if (m.text.size() > kMaxSimCommandText) {
    Refuse(channel, "text", std::to_string(m.text.size()) + " bytes",
           "at most " + std::to_string(kMaxSimCommandText) + " bytes");
  }
  command.name = m.name;
  command.text = m.text;
  return command;
}

// ---- logger_command_t

sirupp::logger_command_t ToMessage(const LoggerCommand& command) {
  sirupp::logger_command_t m{};
  m.utime = command.utime;
  m.seq = command.seq;
  m.sender = command.sender;
  m.command = command.action == LoggerAction::kStart ? sirupp::logger_command_t::COMMAND_START
                                                     : sirupp::logger_command_t::COMMAND_STOP;
  m.name = command.name;
  return m;
}

LoggerCommand LoggerCommandFromMessage(const sirupp::logger_command_t& m,
                                       const std::string& channel) {
  LoggerCommand command;
  command.utime = m.utime;
  command.seq = m.seq;
  command.sender = m.sender;
  if (m.command == sirupp::logger_command_t::COMMAND_START) {
    command.action = LoggerAction::kStart;
  } else if (m.command == sirupp::logger_command_t::COMMAND_STOP) {
    command.action = LoggerAction::kStop;
  } else {
    Refuse(channel, "command", std::to_string(m.command), "0 (start) or 1 (stop)");
  }
  command.name = m.name;
  return command;
}

// ---- logger_pass_t

sirupp::logger_pass_t ToMessage(const LoggerPass& pass) {
  sirupp::logger_pass_t m{};
  m.utime = pass.utime;
  m.seq = pass.seq;
  m.taken = pass.taken;
  m.last = I8(pass.last);
  m.started_utime = pass.started_utime;
  m.name = pass.name;
  m.lcm_url = pass.lcm_url;
  m.period_us = pass.period_us;
  m.max_age_us = pass.max_age_us;
  m.idle_us = pass.idle_us;
  m.split_per_plan = I8(pass.split_per_plan);
  m.velocities = I8(pass.velocities);
  m.efforts = I8(pass.efforts);
  m.note = pass.note;
  m.model_file = pass.model_file;
  m.prefix = pass.prefix;
  return m;
}

LoggerPass LoggerPassFromMessage(const sirupp::logger_pass_t& m, const std::string& channel) {
  LoggerPass pass;
  pass.utime = m.utime;
  pass.seq = m.seq;
  if (m.taken < 0) Refuse(channel, "taken", std::to_string(m.taken), "0 or more messages");
  pass.taken = m.taken;
  if (m.last != 0 && m.last != 1) {
    Refuse(channel, "last", std::to_string(m.last), "0 (more passes) or 1 (the last)");
  }
  pass.last = m.last == 1;
  pass.started_utime = m.started_utime;
  pass.name = m.name;
  pass.lcm_url = m.lcm_url;
  if (m.period_us < 1) Refuse(channel, "period_us", std::to_string(m.period_us), "1 us or more");
  pass.period_us = m.period_us;
  if (m.max_age_us < 0) {
    Refuse(channel, "max_age_us", std::to_string(m.max_age_us), "0 us or more");
  }
  pass.max_age_us = m.max_age_us;
  if (m.idle_us < 1) Refuse(channel, "idle_us", std::to_string(m.idle_us), "1 us or more");
  pass.idle_us = m.idle_us;
  const auto flag = [&](int8_t value, const char* field) {
    if (value != 0 && value != 1) Refuse(channel, field, std::to_string(value), "0 or 1");
    return value == 1;
  };
  pass.split_per_plan = flag(m.split_per_plan, "split_per_plan");
  pass.velocities = flag(m.velocities, "velocities");
  pass.efforts = flag(m.efforts, "efforts");
  pass.note = m.note;
  pass.model_file = m.model_file;
  pass.prefix = m.prefix;
  return pass;
}

// ---- sim_reset_t

sirupp::sim_reset_t ToMessage(const SimReset& reset) {
  sirupp::sim_reset_t m{};
  m.utime = reset.utime;
  m.seq = reset.seq;
  m.sender = reset.sender;
  m.num_joints = Count(reset.position.size());
  m.position = reset.position;
  m.num_velocities = Count(reset.velocity.size());
  m.velocity = reset.velocity;
  m.reset_objects = I8(reset.reset_objects);
  return m;
}

SimReset SimResetFromMessage(const sirupp::sim_reset_t& m, const std::string& channel) {
  CheckArray(channel, "num_joints", m.num_joints, "position", m.position);
  CheckArray(channel, "num_velocities", m.num_velocities, "velocity", m.velocity);
  if (m.num_velocities != 0 && m.num_velocities != m.num_joints) {
    Refuse(channel, "num_velocities", std::to_string(m.num_velocities),
           "0 or num_joints (" + std::to_string(m.num_joints) + ")");
  }
  SimReset reset;
  reset.utime = m.utime;
  reset.seq = m.seq;
  reset.sender = m.sender;
  for (size_t i = 0; i < m.position.size(); ++i)
    Finite(channel, Field("position", i), m.position[i]);
  for (size_t i = 0; i < m.velocity.size(); ++i)
    Finite(channel, Field("velocity", i), m.velocity[i]);
  reset.position = m.position;
  reset.velocity = m.velocity;
  reset.reset_objects = Flag(channel, "reset_objects", m.reset_objects);
  return reset;
}

// ---- viewer_camera_t

sirupp::viewer_camera_t ToMessage(const ViewerCamera& camera) {
  sirupp::viewer_camera_t m{};
  m.utime = camera.utime;
  m.seq = camera.seq;
  m.set_camera = I8(camera.set_camera);
  m.azimuth = camera.azimuth;
  m.elevation = camera.elevation;
  m.distance = camera.distance;
  PutVector(camera.target, m.target);
  m.show_frames = I8(camera.show_frames);
  m.show_ghost = I8(camera.show_ghost);
  m.snapshot = I8(camera.snapshot);
  return m;
}

ViewerCamera ViewerCameraFromMessage(const sirupp::viewer_camera_t& m, const std::string& channel) {
  ViewerCamera camera;
  camera.utime = m.utime;
  camera.seq = m.seq;
  camera.set_camera = Flag(channel, "set_camera", m.set_camera);
  if (camera.set_camera) {
    camera.azimuth = Finite(channel, "azimuth", m.azimuth);
    camera.elevation = Finite(channel, "elevation", m.elevation);
    if (!(std::isfinite(m.distance) && m.distance > 0)) {
      Refuse(channel, "distance", FormatNumber(m.distance), "a finite number > 0 (m)");
    }
    camera.distance = m.distance;
    for (size_t i = 0; i < 3; ++i) Finite(channel, Field("target", i), m.target[i]);
    camera.target = GetVector(m.target);
  } else {
    // Not applied; kept as sent so that the message reads back the same.
    camera.azimuth = m.azimuth;
    camera.elevation = m.elevation;
    camera.distance = m.distance;
    camera.target = GetVector(m.target);
  }
  const char* switches = "SWITCH_KEEP, SWITCH_ON, SWITCH_OFF";
  camera.show_frames = EnumValue<Switch>(channel, "show_frames", m.show_frames, 2, switches);
  camera.show_ghost = EnumValue<Switch>(channel, "show_ghost", m.show_ghost, 2, switches);
  camera.snapshot = Flag(channel, "snapshot", m.snapshot);
  return camera;
}

// ---- controller_status_t

sirupp::controller_status_t ToMessage(const ControllerStatus& status) {
  sirupp::controller_status_t m{};
  m.utime = status.utime;
  m.seq = status.seq;
  m.mode = I8(status.mode);
  m.state = I8(status.state);
  m.move_id = status.move_id;
  m.plan_name = status.plan_name;
  m.plan_step = status.plan_step;
  m.plan_steps = status.plan_steps;
  m.plan_line = status.plan_line;
  m.last_error = status.last_error;
  return m;
}

ControllerStatus ControllerStatusFromMessage(const sirupp::controller_status_t& m,
                                             const std::string& channel) {
  ControllerStatus status;
  status.utime = m.utime;
  status.seq = m.seq;
  status.mode =
      EnumValue<ControllerMode>(channel, "mode", m.mode, 1, "MODE_MANUAL, MODE_AUTOMATIC");
  status.state = EnumValue<ControllerState>(channel, "state", m.state, 5, "STATE_*");
  status.move_id = m.move_id;
  status.plan_name = m.plan_name;
  if (m.plan_step < -1)
    Refuse(channel, "plan_step", std::to_string(m.plan_step), "-1 (no plan) or >= 0");
  status.plan_step = m.plan_step;
  status.plan_steps = static_cast<int32_t>(NonNegativeCount(channel, "plan_steps", m.plan_steps));
  status.plan_line = static_cast<int32_t>(NonNegativeCount(channel, "plan_line", m.plan_line));
  status.last_error = m.last_error;
  return status;
}

// ---- hardware_status_t

sirupp::hardware_status_t ToMessage(const HardwareStatus& status) {
  sirupp::hardware_status_t m{};
  m.utime = status.utime;
  m.seq = status.seq;
  m.state = I8(status.state);
  m.calibrated = I8(status.calibrated);
  m.port = status.port;
  m.baud = status.baud;
  m.num_joints = Count(status.modules.size());
  for (const ModuleReading& module : status.modules) {
    m.module_status.push_back(module.status);
    m.module_aux_status.push_back(module.aux_status);
    m.position_counts.push_back(module.position_counts);
    m.position_error_counts.push_back(module.position_error_counts);
  }
  m.checksum_errors = status.checksum_errors;
  m.timeouts = status.timeouts;
  m.resyncs = status.resyncs;
  m.last_error = status.last_error;
  return m;
}

HardwareStatus HardwareStatusFromMessage(const sirupp::hardware_status_t& m,
                                         const std::string& channel) {
  CheckArray(channel, "num_joints", m.num_joints, "module_status", m.module_status);
  CheckArray(channel, "num_joints", m.num_joints, "module_aux_status", m.module_aux_status);
  CheckArray(channel, "num_joints", m.num_joints, "position_counts", m.position_counts);
  CheckArray(channel, "num_joints", m.num_joints, "position_error_counts", m.position_error_counts);
  HardwareStatus status;
  status.utime = m.utime;
  status.seq = m.seq;
  status.state = EnumValue<BridgeState>(channel, "state", m.state, 6, "STATE_*");
  status.calibrated = Flag(channel, "calibrated", m.calibrated);
  status.port = m.port;
  status.baud = static_cast<int32_t>(NonNegativeCount(channel, "baud", m.baud));
  for (size_t i = 0; i < m.module_status.size(); ++i) {
    status.modules.push_back(ModuleReading{m.module_status[i], m.module_aux_status[i],
                                           m.position_counts[i], m.position_error_counts[i]});
  }
  status.checksum_errors = NonNegativeCount(channel, "checksum_errors", m.checksum_errors);
  status.timeouts = NonNegativeCount(channel, "timeouts", m.timeouts);
  status.resyncs = NonNegativeCount(channel, "resyncs", m.resyncs);
  status.last_error = m.last_error;
  return status;
}

// ---- sim_status_t

sirupp::sim_status_t ToMessage(const SimStatus& status) {
  sirupp::sim_status_t m{};
  m.utime = status.utime;
  m.seq = status.seq;
  m.run_id = status.run_id;
  m.mode = I8(status.mode);
  m.tick = status.tick;
  m.sim_time_s = status.sim_time_s;
  m.realtime_factor = status.realtime_factor;
  m.realtime_factor_run = status.realtime_factor_run;
  m.slipped_s = status.slipped_s;
  m.estop = I8(status.estop);
  m.estop_reason = status.estop_reason;
  m.num_participants = Count(status.participants.size());
  for (const ParticipantReport& p : status.participants) {
    m.participant.push_back(p.name);
    m.participant_state.push_back(I8(p.state));
    m.answer_mean_ms.push_back(p.answer_mean_ms);
    m.answer_max_ms.push_back(p.answer_max_ms);
  }
  m.num_refused = Count(status.refused.size());
  for (const RefusalReport& r : status.refused) {
    m.refused_sender.push_back(r.sender);
    m.refused_count.push_back(r.count);
    m.refused_reason.push_back(r.reason);
  }
  m.refused_others = status.refused_others;
  m.detail = status.detail;
  return m;
}

SimStatus SimStatusFromMessage(const sirupp::sim_status_t& m, const std::string& channel) {
  CheckArray(channel, "num_participants", m.num_participants, "participant", m.participant);
  CheckArray(channel, "num_participants", m.num_participants, "participant_state",
             m.participant_state);
  CheckArray(channel, "num_participants", m.num_participants, "answer_mean_ms", m.answer_mean_ms);
  CheckArray(channel, "num_participants", m.num_participants, "answer_max_ms", m.answer_max_ms);
  CheckArray(channel, "num_refused", m.num_refused, "refused_sender", m.refused_sender);
  CheckArray(channel, "num_refused", m.num_refused, "refused_count", m.refused_count);
  CheckArray(channel, "num_refused", m.num_refused, "refused_reason", m.refused_reason);
  SimStatus status;
  status.utime = m.utime;
  status.seq = m.seq;
  status.run_id = m.run_id;
  status.mode = EnumValue<TimingMode>(channel, "mode", m.mode, 3,
                                      "MODE_LOCKSTEP, MODE_REALTIME, MODE_FAST, MODE_FREERUN");
  status.tick = m.tick;
  status.sim_time_s = Finite(channel, "sim_time_s", m.sim_time_s);
  status.realtime_factor = NonNegative(channel, "realtime_factor", m.realtime_factor);
  status.realtime_factor_run = NonNegative(channel, "realtime_factor_run", m.realtime_factor_run);
  status.slipped_s = Finite(channel, "slipped_s", m.slipped_s);
  status.estop = Flag(channel, "estop", m.estop);
  status.estop_reason = m.estop_reason;
  for (size_t i = 0; i < m.participant.size(); ++i) {
    ParticipantReport p;
    p.name = m.participant[i];
    p.state = EnumValue<ParticipantState>(channel, Field("participant_state", i),
                                          m.participant_state[i], 2, "PARTICIPANT_*");
    p.answer_mean_ms = NonNegative(channel, Field("answer_mean_ms", i), m.answer_mean_ms[i]);
    p.answer_max_ms = NonNegative(channel, Field("answer_max_ms", i), m.answer_max_ms[i]);
    status.participants.push_back(p);
  }
  for (size_t i = 0; i < m.refused_sender.size(); ++i) {
    status.refused.push_back(
        RefusalReport{m.refused_sender[i],
                      NonNegativeCount(channel, Field("refused_count", i), m.refused_count[i]),
                      m.refused_reason[i]});
  }
  status.refused_others = NonNegativeCount(channel, "refused_others", m.refused_others);
  status.detail = m.detail;
  return status;
}

// ---- command_reply_t

sirupp::command_reply_t ToMessage(const CommandReply& reply) {
  sirupp::command_reply_t m{};
  m.utime = reply.utime;
  m.seq = reply.seq;
  m.sender = reply.sender;
  m.request_channel = reply.request_channel;
  m.request_utime = reply.request_utime;
  m.request_seq = reply.request_seq;
  m.result = reply.accepted ? sirupp::command_reply_t::RESULT_ACCEPTED
                            : sirupp::command_reply_t::RESULT_REFUSED;
  m.error = reply.error;
  m.move_id = reply.move_id;
  m.status_seq = reply.status_seq;
  return m;
}

CommandReply CommandReplyFromMessage(const sirupp::command_reply_t& m, const std::string& channel) {
  CommandReply reply;
  reply.utime = m.utime;
  reply.seq = m.seq;
  reply.sender = m.sender;
  reply.request_channel = m.request_channel;
  reply.request_utime = m.request_utime;
  reply.request_seq = m.request_seq;
  if (m.result != sirupp::command_reply_t::RESULT_ACCEPTED &&
      m.result != sirupp::command_reply_t::RESULT_REFUSED) {
    Refuse(channel, "result", std::to_string(m.result),
           "0 (RESULT_ACCEPTED) or 1 (RESULT_REFUSED)");
  }
  reply.accepted = m.result == sirupp::command_reply_t::RESULT_ACCEPTED;
  if (!reply.accepted && m.error.empty()) {
    Refuse(channel, "error", "an empty reason for a refusal", "the reason the command was refused");
  }
  reply.error = m.error;
  reply.move_id = m.move_id;
  reply.status_seq = m.status_seq;
  return reply;
}

// ---- channel_stats_t, heartbeat_t

sirupp::channel_stats_t ToMessage(const ChannelTraffic& traffic) {
  const ChannelStats& s = traffic.stats;
  sirupp::channel_stats_t m{};
  m.channel = s.channel;
  m.publishing = I8(s.publishing);
  m.messages = s.messages;
  m.decode_errors = s.decode_errors;
  m.rejected = s.rejected;
  m.late = s.late;
  m.gaps = s.gaps;
  m.rate_hz = traffic.rate_hz;
  return m;
}

ChannelTraffic ChannelTrafficFromMessage(const sirupp::channel_stats_t& m,
                                         const std::string& channel, const std::string& field) {
  ChannelTraffic traffic;
  ChannelStats& s = traffic.stats;
  s.channel = m.channel;
  s.publishing = Flag(channel, field + ".publishing", m.publishing);
  s.messages = NonNegativeCount(channel, field + ".messages", m.messages);
  s.decode_errors = NonNegativeCount(channel, field + ".decode_errors", m.decode_errors);
  s.rejected = NonNegativeCount(channel, field + ".rejected", m.rejected);
  s.late = NonNegativeCount(channel, field + ".late", m.late);
  s.gaps = NonNegativeCount(channel, field + ".gaps", m.gaps);
  traffic.rate_hz = NonNegative(channel, field + ".rate_hz", m.rate_hz);
  return traffic;
}

sirupp::heartbeat_t ToMessage(const HeartbeatReport& heartbeat) {
  sirupp::heartbeat_t m{};
  m.utime = heartbeat.utime;
  m.seq = heartbeat.seq;
  m.process = heartbeat.process;
  m.host = heartbeat.host;
  m.pid = heartbeat.pid;
  m.state = I8(heartbeat.state);
  m.detail = heartbeat.detail;
  m.uptime_s = heartbeat.uptime_s;
  for (const ChannelTraffic& traffic : heartbeat.channels) m.channels.push_back(ToMessage(traffic));
  m.num_channels = Count(m.channels.size());
  return m;
}

HeartbeatReport HeartbeatFromMessage(const sirupp::heartbeat_t& m, const std::string& channel) {
  CheckArray(channel, "num_channels", m.num_channels, "channels", m.channels);
  HeartbeatReport heartbeat;
  heartbeat.utime = m.utime;
  heartbeat.seq = m.seq;
  heartbeat.process = m.process;
  heartbeat.host = m.host;
  heartbeat.pid = m.pid;
  heartbeat.state = EnumValue<ProcessState>(channel, "state", m.state, 4, "STATE_*");
  heartbeat.detail = m.detail;
  heartbeat.uptime_s = NonNegative(channel, "uptime_s", m.uptime_s);
  for (size_t i = 0; i < m.channels.size(); ++i) {
    heartbeat.channels.push_back(
        ChannelTrafficFromMessage(m.channels[i], channel, Field("channels", i).str()));
  }
  return heartbeat;
}

// ---- image_metadata_t, image_t

sirupp::image_metadata_t ToMessage(const ImageMetadata& metadata) {
  sirupp::image_metadata_t m{};
  m.key = metadata.key;
  m.value = metadata.value;
  m.n = Count(m.value.size());
  return m;
}

ImageMetadata ImageMetadataFromMessage(const sirupp::image_metadata_t& m,
                                       const std::string& channel, const std::string& field) {
  CheckArray(channel, (field + ".n").c_str(), m.n, field + ".value", m.value);
  return ImageMetadata{m.key, m.value};
}

sirupp::image_t ToMessage(const Image& image) {
  sirupp::image_t m{};
  m.utime = image.utime;
  m.width = image.width;
  m.height = image.height;
  m.row_stride = image.row_stride;
  m.pixelformat = image.pixelformat;
  m.data = image.data;
  m.size = Count(m.data.size());
  for (const ImageMetadata& metadata : image.metadata) m.metadata.push_back(ToMessage(metadata));
  m.nmetadata = Count(m.metadata.size());
  return m;
}

Image ImageFromMessage(const sirupp::image_t& m, const std::string& channel) {
  CheckArray(channel, "size", m.size, "data", m.data);
  CheckArray(channel, "nmetadata", m.nmetadata, "metadata", m.metadata);
  Image image;
  image.utime = m.utime;
  image.width = static_cast<int32_t>(NonNegativeCount(channel, "width", m.width));
  image.height = static_cast<int32_t>(NonNegativeCount(channel, "height", m.height));
  image.row_stride = static_cast<int32_t>(NonNegativeCount(channel, "row_stride", m.row_stride));
  image.pixelformat = m.pixelformat;
  image.data = m.data;
  for (size_t i = 0; i < m.metadata.size(); ++i) {
    image.metadata.push_back(
        ImageMetadataFromMessage(m.metadata[i], channel, Field("metadata", i).str()));
  }
  return image;
}

}  // namespace sirupp::core
