#pragma once
// A movement plan's collision check: the set-points the controller would send for it
// (TracePlanSetpoints), swept through the arm's collision model in its world (planning/sweep.hpp).
// One function for `sirupp plan check --env` (which prints the report) and sirupp-control (which
// refuses a plan whose report has an error while the sim has an environment).

#include <optional>
#include <string>
#include <vector>

#include "control/plan.hpp"
#include "planning/collision_model.hpp"
#include "planning/sweep.hpp"

namespace sirupp::control {

// The check's default edge resolution: no joint moves more than this between two checked
// set-points (rad).
inline constexpr double kPlanCheckStepRad = 0.01;

struct PlanCollisionReport {
  std::optional<planning::SweepFinding> error;       // the first static-object or self contact
  std::vector<planning::SweepFinding> free_touches;  // before the error (free objects: notes)
  int states_checked = 0;
  double duration_s = 0;  // of the plan's motion (up to the error)
};

// Sweeps `plan` from `start` (SI, one per joint); each move's end is checked whatever the step.
PlanCollisionReport CheckPlanCollisions(const core::RobotModel& model, const Plan& plan,
                                        const std::vector<double>& start,
                                        planning::CollisionModel& collision, double step_rad);

// Joints as text: degrees for revolute joints, metres for prismatic, 2 decimals, space-separated.
std::string JointsText(const core::RobotModel& model, const core::JointVector& q);
// Where a finding is in the plan: "NAME:LINE: TEXT", or "NAME: at the start".
std::string FindingPlace(const Plan& plan, const planning::SweepFinding& finding);
// What touches and where: the model's description, the joints in the model's units, the time.
std::string FindingDetail(const core::RobotModel& model, const planning::CollisionModel& collision,
                          const planning::SweepFinding& finding);
// The error line: "PLACE: collision: DETAIL" or "PLACE: the arm hits itself: DETAIL".
std::string FindingError(const core::RobotModel& model, const Plan& plan,
                         const planning::CollisionModel& collision,
                         const planning::SweepFinding& finding);

}  // namespace sirupp::control
