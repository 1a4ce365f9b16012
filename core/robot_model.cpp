#include "core/robot_model.hpp"

#include <cmath>
#include <cstdio>
#include <set>

#include "core/errors.hpp"
#include "core/mass_properties.hpp"

namespace sirupp::core {

const char* DhConventionName(DhConvention convention) {
  return convention == DhConvention::kStandard ? "standard" : "modified";
}

const char* JointTypeName(JointType type) {
  return type == JointType::kRevolute ? "revolute" : "prismatic";
}

const NamedPose* RobotModel::FindNamedPose(const std::string& pose_name) const {
  for (const NamedPose& pose : named_poses) {
    if (pose.name == pose_name) return &pose;
  }
  return nullptr;
}

std::string Fnv1aHex(const std::string& bytes) {
  uint64_t hash = 0xcbf29ce484222325ULL;
  for (unsigned char byte : bytes) {
    hash ^= byte;
    hash *= 0x100000001b3ULL;
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

namespace {

// Shows SI values in the units the model's file used, so messages match what the user wrote.
class UnitShow {
 public:
  explicit UnitShow(const RobotModel& model) : model_(model) {}

  // A joint position (or speed, with `suffix` "/s") in the file's units for that joint type.
  std::string Position(const Joint& joint, double value, const char* suffix = "") const {
    if (joint.type == JointType::kPrismatic) return Length(value) + suffix;
    if (model_.file_angle_unit == "deg") {
      return FormatApprox(value * 180.0 / M_PI) + " deg" + suffix;
    }
    return FormatApprox(value) + " rad" + suffix;
  }
  std::string Length(double value_m) const {
    return FormatApprox(value_m / model_.file_length_unit_m) + " " + model_.file_length_unit;
  }

 private:
  const RobotModel& model_;
};

std::string Index(const char* list, size_t i) {
  return std::string(list) + "[" + std::to_string(i) + "]";
}

bool Positive(double value) { return std::isfinite(value) && value > 0; }
bool NonNegative(double value) { return std::isfinite(value) && value >= 0; }

// Names the field of joints[i] a problem is about: "joints[2].friction.viscous".
class JointField {
 public:
  JointField(const RobotModel& model, size_t i)
      : joint(model.joints[i]),
        show(model),
        effort_unit(joint.type == JointType::kRevolute ? "N*m" : "N"),
        at_(Index("joints", i)) {}
  ModelProblem operator()(const std::string& key, const std::string& text) const {
    return ModelProblem{at_ + (key.empty() ? "" : "." + key), text};
  }

  const Joint& joint;
  const UnitShow show;
  const char* const effort_unit;

 private:
  const std::string at_;
};

// Name, DH row, limits, speed, effort, armature and home of joints[i].
std::optional<ModelProblem> JointRangeProblem(const RobotModel& model, size_t i) {
  const JointField problem(model, i);
  const Joint& joint = problem.joint;
  const UnitShow& show = problem.show;
  const char* effort_unit = problem.effort_unit;

  if (joint.name.empty()) return problem("name", "is empty; expected a joint name");
  for (size_t k = 0; k < i; ++k) {
    if (model.joints[k].name == joint.name) {
      return problem("name", "'" + joint.name + "' is already the name of joints[" +
                                 std::to_string(k) + "]; expected unique joint names");
    }
  }
  const DhRow& dh = joint.dh;
  if (!std::isfinite(dh.a_m) || !std::isfinite(dh.alpha_rad) || !std::isfinite(dh.d_m) ||
      !std::isfinite(dh.theta_rad)) {
    return ModelProblem{Index("dh", i),
                        "has a non-finite value; expected finite a, alpha, d, theta"};
  }
  if (!std::isfinite(joint.position_min) || !std::isfinite(joint.position_max)) {
    return problem("limits", "are not finite; expected two finite numbers, min < max");
  }
  if (joint.position_min >= joint.position_max) {
    return problem("limits", "min " + show.Position(joint, joint.position_min) +
                                 " is not below max " + show.Position(joint, joint.position_max) +
                                 "; expected min < max");
  }
  if (!Positive(joint.velocity_max)) {
    return problem("max_velocity", show.Position(joint, joint.velocity_max, "/s") +
                                       " is not allowed; expected a speed > 0");
  }
  if (!Positive(joint.effort_max)) {
    return problem("max_effort", FormatApprox(joint.effort_max) + " " + effort_unit +
                                     " is not allowed; expected an effort > 0");
  }
  if (!NonNegative(joint.armature)) {
    return problem("armature", FormatApprox(joint.armature) + " is not allowed; expected >= 0");
  }
  if (!std::isfinite(joint.home) || joint.home < joint.position_min ||
      joint.home > joint.position_max) {
    return problem("home", show.Position(joint, joint.home) + " is outside the limits [" +
                               show.Position(joint, joint.position_min) + ", " +
                               show.Position(joint, joint.position_max) + "]");
  }
  return std::nullopt;
}

std::optional<ModelProblem> FrictionProblem(const RobotModel& model, size_t i) {
  const JointField problem(model, i);
  const UnitShow& show = problem.show;
  const Joint& joint = problem.joint;
  const char* effort_unit = problem.effort_unit;
  const Friction& f = joint.friction;
  if (!NonNegative(f.coulomb_positive) || !NonNegative(f.coulomb_negative)) {
    return problem("friction.coulomb", "levels " + FormatApprox(f.coulomb_positive) + ", " +
                                           FormatApprox(f.coulomb_negative) + " " + effort_unit +
                                           " are not allowed; expected both >= 0");
  }
  if (!std::isfinite(f.static_effort) ||
      f.static_effort < std::max(f.coulomb_positive, f.coulomb_negative)) {
    return problem(
        "friction.static",
        FormatApprox(f.static_effort) + " " + effort_unit + " is below the Coulomb level " +
            FormatApprox(std::max(f.coulomb_positive, f.coulomb_negative)) + " " + effort_unit +
            "; expected static >= coulomb (break-away needs at least sliding friction)");
  }
  if (!NonNegative(f.viscous)) {
    return problem("friction.viscous", FormatApprox(f.viscous) + " is not allowed; expected >= 0");
  }
  if (!Positive(f.stribeck_velocity)) {
    return problem("friction.stribeck_velocity", show.Position(joint, f.stribeck_velocity, "/s") +
                                                     " is not allowed; expected > 0");
  }
  return std::nullopt;
}

// The servo parameters the PIC-SERVO SC takes as integers in a range.
std::optional<ModelProblem> ChipProblem(const JointField& problem, const ServoParams& s) {
  struct ChipField {
    const char* key;
    double value;
    double min;
    double max;
  };
  const ChipField chip_fields[] = {
      {"kp", s.kp, 0, 32767},
      {"kd", s.kd, 0, 32767},
      {"ki", s.ki, 0, 32767},
      {"integration_limit", s.integration_limit, 0, 32767},
      {"output_limit", s.output_limit, 0, 255},
      {"current_limit", s.current_limit, 0, 255},
      {"error_limit", s.error_limit, 0, 32767},
      {"servo_rate_divisor", s.servo_rate_divisor, 1, 255},
      {"deadband", s.deadband, 0, 255},
  };
  for (const ChipField& field : chip_fields) {
    if (!std::isfinite(field.value) || field.value < field.min || field.value > field.max ||
        field.value != std::floor(field.value)) {
      return problem(std::string("servo.") + field.key,
                     FormatApprox(field.value) + " is not allowed; expected an integer in [" +
                         FormatNumber(field.min) + ", " + FormatNumber(field.max) +
                         "] (PIC-SERVO SC units)");
    }
  }
  return std::nullopt;
}

std::optional<ModelProblem> ServoProblem(const RobotModel& model, size_t i) {
  const JointField problem(model, i);
  const UnitShow& show = problem.show;
  const Joint& joint = problem.joint;
  const ServoParams& s = joint.servo;
  if (!Positive(s.encoder_counts_per_rev)) {
    return problem("servo.encoder_counts_per_rev",
                   FormatApprox(s.encoder_counts_per_rev) + " is not allowed; expected > 0");
  }
  if (!std::isfinite(s.gear_ratio) || s.gear_ratio == 0) {
    return problem("servo.gear_ratio",
                   FormatApprox(s.gear_ratio) + " is not allowed; expected a non-zero ratio");
  }
  if (!Positive(s.motor_torque_max_nm)) {
    return problem("servo.motor_torque_max_nm",
                   FormatApprox(s.motor_torque_max_nm) + " is not allowed; expected > 0 (N*m)");
  }
  if (!Positive(s.default_velocity) || s.default_velocity > joint.velocity_max) {
    return problem("servo.default_velocity",
                   show.Position(joint, s.default_velocity, "/s") +
                       " is not allowed; expected > 0 and <= max_velocity " +
                       show.Position(joint, joint.velocity_max, "/s"));
  }
  if (!Positive(s.default_acceleration)) {
    return problem(
        "servo.default_acceleration",
        show.Position(joint, s.default_acceleration, "/s^2") + " is not allowed; expected > 0");
  }
  return ChipProblem(problem, s);
}

std::optional<ModelProblem> JointProblem(const RobotModel& model, size_t i) {
  if (auto problem = JointRangeProblem(model, i)) return problem;
  if (auto problem = FrictionProblem(model, i)) return problem;
  return ServoProblem(model, i);
}

std::optional<ModelProblem> LinkProblem(const RobotModel& model, size_t i) {
  const Link& link = model.links[i];
  const std::string at = Index("links", i);
  if (link.name.empty()) return ModelProblem{at + ".name", "is empty; expected a link name"};
  const bool base = i == 0;
  if (!std::isfinite(link.mass_kg) || (base ? link.mass_kg < 0 : link.mass_kg <= 0)) {
    return ModelProblem{at + ".mass_kg", FormatApprox(link.mass_kg) + " is not allowed; expected " +
                                             (base ? "a mass >= 0 (kg) for the fixed base"
                                                   : "a mass > 0 (kg) for a moving link")};
  }
  for (size_t k = 0; k < link.shapes.size(); ++k) {
    const Shape& shape = link.shapes[k];
    const int used = shape.type == ShapeType::kBox ? 3 : shape.type == ShapeType::kSphere ? 1 : 2;
    for (int axis = 0; axis < used; ++axis) {
      if (!std::isfinite(shape.size_m[axis]) || shape.size_m[axis] <= 0) {
        return ModelProblem{at + ".shapes[" + std::to_string(k) + "]",
                            std::string(ShapeTypeName(shape.type)) + " has size " +
                                FormatApprox(shape.size_m[axis]) +
                                " m; expected every dimension > 0"};
      }
    }
    if (!shape.pose.position_m.allFinite() || std::abs(shape.pose.orientation.norm() - 1) > 1e-6) {
      return ModelProblem{at + ".shapes[" + std::to_string(k) + "]",
                          "has a non-finite position or a non-unit orientation"};
    }
  }
  if (base) return std::nullopt;
  if (!link.com_m.allFinite()) {
    return ModelProblem{at + ".com", "is not finite; expected a point in the link frame"};
  }
  if (const auto inertia_problem = InertiaProblem(link.inertia_kg_m2)) {
    return ModelProblem{at + (link.inertia_derived ? ".shapes" : ".inertia_kg_m2"),
                        (link.inertia_derived ? "give an inertia that " : "") + *inertia_problem};
  }
  return std::nullopt;
}

}  // namespace

std::optional<ModelProblem> FindModelProblem(const RobotModel& model) {
  if (model.name.empty()) return ModelProblem{"name", "is empty; expected a model name"};
  if (model.joints.empty()) return ModelProblem{"joints", "is empty; expected at least one joint"};
  if (!(model.servo_tick_s > 0) || !std::isfinite(model.servo_tick_s)) {
    return ModelProblem{"servo_tick_s", FormatApprox(model.servo_tick_s) +
                                            " is not allowed; expected a tick > 0 (s)"};
  }
  if (!model.gravity_m_s2.allFinite()) {
    return ModelProblem{"gravity_m_s2", "is not finite; expected three finite numbers (m/s^2)"};
  }
  for (const auto& [what, pose] : {std::pair<const char*, const Pose*>{"base", &model.base},
                                   std::pair<const char*, const Pose*>{"tool", &model.tool}}) {
    if (!pose->position_m.allFinite() || std::abs(pose->orientation.norm() - 1) > 1e-6) {
      return ModelProblem{what, "has a non-finite position or a non-unit orientation"};
    }
  }
  for (size_t i = 0; i < model.joints.size(); ++i) {
    if (auto problem = JointProblem(model, i)) return problem;
  }
  if (model.links.size() != model.joints.size() + 1) {
    return ModelProblem{"links", std::to_string(model.links.size()) + " links for " +
                                     std::to_string(model.joints.size()) +
                                     " joints; expected the base plus one link per joint (" +
                                     std::to_string(model.joints.size() + 1) + ")"};
  }
  for (size_t i = 0; i < model.links.size(); ++i) {
    if (auto problem = LinkProblem(model, i)) return problem;
  }
  const UnitShow show(model);
  std::set<std::string> pose_names;
  for (const NamedPose& pose : model.named_poses) {
    const std::string at = "named_poses." + pose.name;
    if (pose.name.empty() || !pose_names.insert(pose.name).second) {
      return ModelProblem{"named_poses", "'" + pose.name + "' is empty or repeated"};
    }
    if (pose.position.size() != model.joints.size()) {
      return ModelProblem{at, std::to_string(pose.position.size()) +
                                  (pose.position.size() == 1 ? " value for " : " values for ") +
                                  std::to_string(model.joints.size()) +
                                  " joints; expected one value per joint"};
    }
    for (size_t j = 0; j < pose.position.size(); ++j) {
      const Joint& joint = model.joints[j];
      if (!std::isfinite(pose.position[j]) || pose.position[j] < joint.position_min ||
          pose.position[j] > joint.position_max) {
        return ModelProblem{at + "[" + std::to_string(j) + "]",
                            show.Position(joint, pose.position[j]) + " is outside joint " +
                                joint.name + "'s limits [" +
                                show.Position(joint, joint.position_min) + ", " +
                                show.Position(joint, joint.position_max) + "]"};
      }
    }
  }
  return std::nullopt;
}

}  // namespace sirupp::core
