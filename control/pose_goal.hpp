#pragma once
// Joint goals for an end-effector target: the kinematics library's IK, then one solution picked by
// configuration (PUMA-type arms, closed form) or the one nearest the reference joints. Shared by
// ARM_POSE_TARGET handling and the plan's `move tool` steps, so both choose the same way.

#include <optional>
#include <string>

#include "core/inverse_kinematics.hpp"
#include "core/robot_model.hpp"

namespace sirupp::control {

struct PoseRequest {
  Eigen::Isometry3d target = Eigen::Isometry3d::Identity();  // tool pose, world frame
  // Wanted configuration, field by field (nullopt = free). With every field free the solution
  // nearest the reference is taken; otherwise the nearest among those that match.
  std::optional<bool> shoulder_left;
  std::optional<bool> elbow_up;
  std::optional<bool> wrist_flip;
  bool position_only = false;

  void SetConfig(const core::IkConfiguration& config) {
    shoulder_left = config.shoulder_left;
    elbow_up = config.elbow_up;
    wrist_flip = config.wrist_flip;
  }
  bool HasConfig() const { return shoulder_left || elbow_up || wrist_flip; }
  // "left-up-noflip", with "any" for free fields.
  std::string ConfigName() const;
  bool Matches(const core::IkConfiguration& config) const;
};

struct PoseGoal {
  bool ok = false;
  core::JointVector q;      // the chosen joints when ok
  std::string config_name;  // its configuration ("right-up-noflip"), empty for numeric solutions
  std::string reason;       // one line for people when !ok
};

// Never throws on an unreachable target: returns ok = false with the reason (unreachable, outside
// the joint limits, no solution in the asked configuration, configuration asked where the
// closed-form solver does not apply).
PoseGoal SolvePoseGoal(const core::RobotModel& model, const PoseRequest& request,
                       const core::JointVector& reference);

}  // namespace sirupp::control
