#include "core/motion_limits.hpp"

#include <cmath>
#include <stdexcept>

#include "core/errors.hpp"

namespace sirupp::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string Shown(const Joint& joint, double v) {
  if (joint.type == JointType::kRevolute) return FormatApprox(v * 180 / kPi) + " deg";
  return FormatApprox(v) + " m";
}
std::string ShownRate(const Joint& joint, double v, const char* per) {
  if (joint.type == JointType::kRevolute) return FormatApprox(v * 180 / kPi) + " deg/" + per;
  return FormatApprox(v) + " m/" + per;
}

const Joint& JointAt(const RobotModel& model, int j) {
  if (j < 0 || j >= model.num_joints()) {
    throw std::out_of_range("joint index " + std::to_string(j) + ": the model " + model.name +
                            " has joints 0.." + std::to_string(model.num_joints() - 1));
  }
  return model.joints[static_cast<size_t>(j)];
}

}  // namespace

MotionLimits DefaultMotionLimits(const RobotModel& model) {
  MotionLimits limits;
  limits.soft_limit_margin = kDefaultSoftLimitMarginDeg * kPi / 180;
  for (const Joint& joint : model.joints) {
    limits.acceleration_max.push_back(4 * joint.servo.default_acceleration);
  }
  return limits;
}

double SoftMin(const RobotModel& model, const MotionLimits& limits, int j) {
  return JointAt(model, j).position_min + limits.soft_limit_margin;
}
double SoftMax(const RobotModel& model, const MotionLimits& limits, int j) {
  return JointAt(model, j).position_max - limits.soft_limit_margin;
}

std::optional<std::string> CheckJointMove(const RobotModel& model, const MotionLimits& limits,
                                          int j, double goal, double speed, double acceleration,
                                          bool velocity_mode) {
  const Joint& joint = JointAt(model, j);
  const std::string where = "joint j" + std::to_string(j + 1) + " (" + joint.name + "): ";
  const double v_cap = joint.velocity_max * limits.velocity_cap_fraction;
  if (!std::isfinite(speed) || (velocity_mode ? speed == 0 : speed <= 0) ||
      std::abs(speed) > v_cap) {
    return where + "speed " + ShownRate(joint, speed, "s") + " is outside (0, " +
           ShownRate(joint, v_cap, "s") + "] (velocity cap)";
  }
  const auto i = static_cast<size_t>(j);
  const double a_cap = i < limits.acceleration_max.size() ? limits.acceleration_max[i] : 0.0;
  if (!std::isfinite(acceleration) || acceleration <= 0 || acceleration > a_cap) {
    return where + "acceleration " + ShownRate(joint, acceleration, "s^2") + " is outside (0, " +
           ShownRate(joint, a_cap, "s^2") + "] (acceleration cap)";
  }
  if (velocity_mode) return std::nullopt;  // the goal is not used; watched while it runs
  const double lo = SoftMin(model, limits, j);
  const double hi = SoftMax(model, limits, j);
  if (!std::isfinite(goal) || goal < lo || goal > hi) {
    return where + "goal " + Shown(joint, goal) + " is outside the soft limits [" +
           Shown(joint, lo) + ", " + Shown(joint, hi) + "]";
  }
  return std::nullopt;
}

}  // namespace sirupp::core
