#include "core/translate.hpp"

#include <cmath>

#include "core/errors.hpp"
#include "core/message_helpers.hpp"

namespace sirupp::core {

namespace {

using detail::CheckCount;
using detail::GetQuaternion;
using detail::GetVector;
using detail::PutQuaternion;
using detail::PutVector;

void CheckJoints(const std::string& channel, int32_t num_joints, int expected_joints) {
  if (num_joints < 0)
    RefuseValue(channel, "num_joints", std::to_string(num_joints), "a count >= 0");
  if (expected_joints >= 0) {
    CheckJointCount(channel, "num_joints", static_cast<size_t>(num_joints), expected_joints);
  }
}

void CheckFinite(const std::string& channel, const std::string& field,
                 const std::vector<double>& values) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      throw MessageError(channel, field + "[" + std::to_string(i) + "]",
                         FormatNumber(values[i]) + " is not allowed; expected a finite number");
    }
  }
}

}  // namespace

void RefuseValue(const std::string& channel, const std::string& field, const std::string& value,
                 const std::string& allowed) {
  throw MessageError(channel, field, value + " is not allowed; expected " + allowed);
}

void CheckJointCount(const std::string& channel, const std::string& field, size_t count,
                     int expected_joints) {
  if (expected_joints < 0 || count != static_cast<size_t>(expected_joints)) {
    RefuseValue(channel, field, std::to_string(count),
                std::to_string(expected_joints) + " (the model's joints)");
  }
}

sirupp::robot_model_t ToMessage(const RobotModel& model, int64_t utime, int64_t seq) {
  sirupp::robot_model_t message{};
  message.utime = utime;
  message.seq = seq;
  message.name = model.name;
  message.description = model.description;
  message.source_file = model.source_file;
  message.source_hash = model.source_hash;
  message.file_length_unit = model.file_length_unit;
  message.file_length_unit_m = model.file_length_unit_m;
  message.file_angle_unit = model.file_angle_unit;
  message.dh_convention = model.dh_convention == DhConvention::kStandard
                              ? sirupp::robot_model_t::DH_STANDARD
                              : sirupp::robot_model_t::DH_MODIFIED;
  PutVector(model.base.position_m, message.base_position);
  PutQuaternion(model.base.orientation, message.base_orientation);
  PutVector(model.tool.position_m, message.tool_position);
  PutQuaternion(model.tool.orientation, message.tool_orientation);
  PutVector(model.gravity_m_s2, message.gravity);
  message.servo_tick_s = model.servo_tick_s;

  for (const Joint& joint : model.joints) message.joints.push_back(ToMessage(joint));
  message.num_joints = static_cast<int32_t>(message.joints.size());

  for (const Link& link : model.links) message.links.push_back(ToMessage(link));
  message.num_links = static_cast<int32_t>(message.links.size());

  for (const NamedPose& pose : model.named_poses) message.named_poses.push_back(ToMessage(pose));
  message.num_named_poses = static_cast<int32_t>(message.named_poses.size());
  return message;
}

RobotModel RobotModelFromMessage(const sirupp::robot_model_t& message, const std::string& channel) {
  CheckCount(channel, "num_joints", message.num_joints, message.joints);
  CheckCount(channel, "num_links", message.num_links, message.links);
  CheckCount(channel, "num_named_poses", message.num_named_poses, message.named_poses);
  RobotModel model;
  model.name = message.name;
  model.description = message.description;
  model.source_file = message.source_file;
  model.source_hash = message.source_hash;
  model.file_length_unit = message.file_length_unit;
  model.file_length_unit_m = message.file_length_unit_m;
  model.file_angle_unit = message.file_angle_unit;
  if (!(model.file_length_unit_m > 0) || !std::isfinite(model.file_length_unit_m)) {
    throw MessageError(channel, "file_length_unit_m",
                       FormatNumber(model.file_length_unit_m) + " is not allowed; expected > 0");
  }
  if (message.dh_convention != sirupp::robot_model_t::DH_STANDARD &&
      message.dh_convention != sirupp::robot_model_t::DH_MODIFIED) {
    throw MessageError(channel, "dh_convention",
                       std::to_string(message.dh_convention) + " is not allowed; expected 0 or 1");
  }
  model.dh_convention = message.dh_convention == sirupp::robot_model_t::DH_STANDARD
                            ? DhConvention::kStandard
                            : DhConvention::kModified;
  model.base.position_m = GetVector(message.base_position);
  model.base.orientation = GetQuaternion(message.base_orientation);
  model.tool.position_m = GetVector(message.tool_position);
  model.tool.orientation = GetQuaternion(message.tool_orientation);
  model.gravity_m_s2 = GetVector(message.gravity);
  model.servo_tick_s = message.servo_tick_s;

  for (size_t i = 0; i < message.joints.size(); ++i) {
    model.joints.push_back(
        JointFromMessage(message.joints[i], channel, "joints[" + std::to_string(i) + "]"));
  }
  for (size_t i = 0; i < message.links.size(); ++i) {
    model.links.push_back(
        LinkFromMessage(message.links[i], channel, "links[" + std::to_string(i) + "]"));
  }
  for (size_t i = 0; i < message.named_poses.size(); ++i) {
    model.named_poses.push_back(NamedPoseFromMessage(message.named_poses[i], channel,
                                                     "named_poses[" + std::to_string(i) + "]"));
  }

  // A received model passes the same physical checks as a loaded file.
  if (const std::optional<ModelProblem> problem = FindModelProblem(model)) {
    throw MessageError(channel, problem->path, problem->problem);
  }
  return model;
}

sirupp::joint_model_t ToMessage(const Joint& joint) {
  sirupp::joint_model_t j{};
  j.name = joint.name;
  j.type = joint.type == JointType::kRevolute ? sirupp::joint_model_t::TYPE_REVOLUTE
                                              : sirupp::joint_model_t::TYPE_PRISMATIC;
  j.dh_a = joint.dh.a_m;
  j.dh_alpha = joint.dh.alpha_rad;
  j.dh_d = joint.dh.d_m;
  j.dh_theta = joint.dh.theta_rad;
  j.position_min = joint.position_min;
  j.position_max = joint.position_max;
  j.velocity_max = joint.velocity_max;
  j.effort_max = joint.effort_max;
  j.armature = joint.armature;
  j.friction_static = joint.friction.static_effort;
  j.friction_coulomb_positive = joint.friction.coulomb_positive;
  j.friction_coulomb_negative = joint.friction.coulomb_negative;
  j.friction_viscous = joint.friction.viscous;
  j.friction_stribeck_velocity = joint.friction.stribeck_velocity;
  const ServoParams& s = joint.servo;
  j.encoder_counts_per_rev = s.encoder_counts_per_rev;
  j.gear_ratio = s.gear_ratio;
  j.motor_torque_max = s.motor_torque_max_nm;
  j.default_velocity = s.default_velocity;
  j.default_acceleration = s.default_acceleration;
  j.kp = s.kp;
  j.kd = s.kd;
  j.ki = s.ki;
  j.integration_limit = s.integration_limit;
  j.output_limit = s.output_limit;
  j.current_limit = s.current_limit;
  j.error_limit = s.error_limit;
  j.servo_rate_divisor = s.servo_rate_divisor;
  j.deadband = s.deadband;
  j.home = joint.home;
  return j;
}

Joint JointFromMessage(const sirupp::joint_model_t& j, const std::string& channel,
                       const std::string& field) {
  if (j.type != sirupp::joint_model_t::TYPE_REVOLUTE &&
      j.type != sirupp::joint_model_t::TYPE_PRISMATIC) {
    throw MessageError(channel, field + ".type",
                       std::to_string(j.type) + " is not allowed; expected 0 or 1");
  }
  Joint joint;
  joint.name = j.name;
  joint.type =
      j.type == sirupp::joint_model_t::TYPE_REVOLUTE ? JointType::kRevolute : JointType::kPrismatic;
  joint.dh = DhRow{j.dh_a, j.dh_alpha, j.dh_d, j.dh_theta};
  joint.position_min = j.position_min;
  joint.position_max = j.position_max;
  joint.velocity_max = j.velocity_max;
  joint.effort_max = j.effort_max;
  joint.armature = j.armature;
  joint.home = j.home;
  joint.friction =
      Friction{j.friction_static, j.friction_coulomb_positive, j.friction_coulomb_negative,
               j.friction_viscous, j.friction_stribeck_velocity};
  ServoParams& s = joint.servo;
  s.encoder_counts_per_rev = j.encoder_counts_per_rev;
  s.gear_ratio = j.gear_ratio;
  s.motor_torque_max_nm = j.motor_torque_max;
  s.default_velocity = j.default_velocity;
  s.default_acceleration = j.default_acceleration;
  s.kp = j.kp;
  s.kd = j.kd;
  s.ki = j.ki;
  s.integration_limit = j.integration_limit;
  s.output_limit = j.output_limit;
  s.current_limit = j.current_limit;
  s.error_limit = j.error_limit;
  s.servo_rate_divisor = j.servo_rate_divisor;
  s.deadband = j.deadband;
  return joint;
}

sirupp::link_model_t ToMessage(const Link& link) {
  sirupp::link_model_t l{};
  l.name = link.name;
  l.mass = link.mass_kg;
  PutVector(link.com_m, l.com);
  const Eigen::Matrix3d& I = link.inertia_kg_m2;
  const double elements[6] = {I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)};
  for (int k = 0; k < 6; ++k) l.inertia[k] = elements[k];
  l.inertia_derived = link.inertia_derived ? 1 : 0;
  for (const Shape& shape : link.shapes) l.shapes.push_back(ToMessage(shape));
  l.num_shapes = static_cast<int32_t>(l.shapes.size());
  return l;
}

Link LinkFromMessage(const sirupp::link_model_t& l, const std::string& channel,
                     const std::string& field) {
  CheckCount(channel, field + ".num_shapes", l.num_shapes, l.shapes);
  Link link;
  link.name = l.name;
  link.mass_kg = l.mass;
  link.com_m = GetVector(l.com);
  link.inertia_kg_m2 << l.inertia[0], l.inertia[3], l.inertia[4], l.inertia[3], l.inertia[1],
      l.inertia[5], l.inertia[4], l.inertia[5], l.inertia[2];
  link.inertia_derived = l.inertia_derived != 0;
  for (size_t k = 0; k < l.shapes.size(); ++k) {
    link.shapes.push_back(
        ShapeFromMessage(l.shapes[k], channel, field + ".shapes[" + std::to_string(k) + "]"));
  }
  return link;
}

sirupp::named_pose_t ToMessage(const NamedPose& pose) {
  sirupp::named_pose_t p{};
  p.name = pose.name;
  p.position = pose.position;
  p.num_joints = static_cast<int32_t>(p.position.size());
  return p;
}

NamedPose NamedPoseFromMessage(const sirupp::named_pose_t& p, const std::string& channel,
                               const std::string& field) {
  CheckCount(channel, field + ".num_joints", p.num_joints, p.position);
  return NamedPose{p.name, p.position};
}

sirupp::shape_t ToMessage(const Shape& shape) { return detail::ShapeToMessage(shape); }

Shape ShapeFromMessage(const sirupp::shape_t& message, const std::string& channel,
                       const std::string& field) {
  return detail::ShapeFromMessage(message, channel, field);
}

sirupp::arm_state_t ToMessage(const ArmState& state, int64_t seq) {
  sirupp::arm_state_t message{};
  message.utime = state.utime;
  message.seq = seq;
  message.tick = state.tick;
  message.source = static_cast<int8_t>(state.source);
  message.num_joints = static_cast<int32_t>(state.position.size());
  message.position = state.position;
  message.velocity = state.velocity;
  message.effort = state.effort;
  message.flags = state.flags;
  const size_t n = state.position.size();
  message.velocity.resize(n, 0.0);
  message.effort.resize(n, 0.0);
  message.flags.resize(n, 0);
  return message;
}

ArmState ArmStateFromMessage(const sirupp::arm_state_t& message, const std::string& channel,
                             int expected_joints) {
  CheckJoints(channel, message.num_joints, expected_joints);
  if (message.source < sirupp::arm_state_t::SOURCE_SIM ||
      message.source > sirupp::arm_state_t::SOURCE_EMULATED) {
    throw MessageError(
        channel, "source",
        std::to_string(message.source) + " is not allowed; expected 0..2 (SOURCE_*)");
  }
  CheckFinite(channel, "position", message.position);
  CheckFinite(channel, "velocity", message.velocity);
  CheckFinite(channel, "effort", message.effort);
  ArmState state;
  state.utime = message.utime;
  state.tick = message.tick;
  state.source = static_cast<StateSource>(message.source);
  state.position = message.position;
  state.velocity = message.velocity;
  state.effort = message.effort;
  state.flags = message.flags;
  return state;
}

sirupp::arm_command_t ToMessage(const ArmCommand& command, int64_t seq) {
  sirupp::arm_command_t message{};
  message.utime = command.utime;
  message.seq = seq;
  message.tick = command.tick;
  message.sender = command.sender;
  message.mode = static_cast<int8_t>(command.mode);
  message.num_joints = static_cast<int32_t>(command.effort.size());
  message.effort = command.effort;
  return message;
}

ArmCommand ArmCommandFromMessage(const sirupp::arm_command_t& message, const std::string& channel,
                                 int expected_joints) {
  CheckJoints(channel, message.num_joints, expected_joints);
  if (message.mode < sirupp::arm_command_t::MODE_EFFORT ||
      message.mode > sirupp::arm_command_t::MODE_BOARDS) {
    throw MessageError(channel, "mode",
                       std::to_string(message.mode) + " is not allowed; expected 0..3 (MODE_*)");
  }
  CheckFinite(channel, "effort", message.effort);
  ArmCommand command;
  command.utime = message.utime;
  command.tick = message.tick;
  command.sender = message.sender;
  command.mode = static_cast<CommandMode>(message.mode);
  command.effort = message.effort;
  return command;
}

}  // namespace sirupp::core
