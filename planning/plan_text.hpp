#pragma once
// A joint-space path as a movement plan (docs/plan-format.md) that the controller runs exactly on
// the checked segments: each segment is one set of `move jK=... speed=... accel=...` lines (one per
// moving joint, all starting in the same servo tick) and `wait done`. Every joint's speed and
// acceleration are in proportion to its change over the segment, so all joints run the same
// normalized trapezoid, start and end together, and the set-point stays on the straight segment
// (up to the PIC-SERVO's integer rounding). The slowest joint sets the pace: its speed is its
// default (the model's servo.default_velocity x speed_fraction, capped at velocity_max) and its
// acceleration its default acceleration x accel_fraction.

#include <string>
#include <vector>

#include "core/kinematics.hpp"
#include "core/robot_model.hpp"

namespace sirupp::planning {

using core::JointVector;

struct PlanTextOptions {
  double speed_fraction = 1.0;  // of each joint's default speed, (0, 1]
  double accel_fraction = 1.0;  // of each joint's default acceleration, (0, 4]
  // Comment lines at the top (each gets "# "), e.g. how the path was made.
  std::vector<std::string> comments;
  // First a `move joints START` + `wait done` (straight to the path's start from wherever the
  // arm is, at default speeds), so the plan runs the same from anywhere (that first move is not
  // planned: `sirupp plan check --env` checks it from the pose it checks from).
  bool move_to_start = true;
};

// The plan text (degrees for revolute joints, metres for prismatic ones). path: at least one
// waypoint, num_joints entries each. Throws std::invalid_argument for an empty path, a wrong
// count or options out of range, and when the text would exceed control's 256 KiB plan limit.
std::string PathToPlanText(const core::RobotModel& model, const std::vector<JointVector>& path,
                           const PlanTextOptions& options = {});

// The duration (s) of one synchronized segment from a to b under `options` (for reports).
double SegmentDuration(const core::RobotModel& model, const JointVector& a, const JointVector& b,
                       const PlanTextOptions& options = {});

}  // namespace sirupp::planning
