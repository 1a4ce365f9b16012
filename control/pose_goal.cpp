#include "control/pose_goal.hpp"

namespace sirupp::control {

std::string PoseRequest::ConfigName() const {
  const auto field = [](const std::optional<bool>& value, const char* yes, const char* no) {
    return value ? std::string(*value ? yes : no) : std::string("any");
  };
  return field(shoulder_left, "left", "right") + "-" + field(elbow_up, "up", "down") + "-" +
         field(wrist_flip, "flip", "noflip");
}

bool PoseRequest::Matches(const core::IkConfiguration& config) const {
  return (!shoulder_left || *shoulder_left == config.shoulder_left) &&
         (!elbow_up || *elbow_up == config.elbow_up) &&
         (!wrist_flip || *wrist_flip == config.wrist_flip);
}

PoseGoal SolvePoseGoal(const core::RobotModel& model, const PoseRequest& request,
                       const core::JointVector& reference) {
  PoseGoal goal;
  // The library's one solver choice; its reason is "position-only target" or the arm's.
  core::IkRequest ik_request;
  ik_request.position_only = request.position_only;
  const core::IkSolverChoice choice = core::ChooseIkSolver(model, ik_request);
  if (request.HasConfig() && !choice.closed_form) {
    goal.reason = "configuration " + request.ConfigName() +
                  " needs the closed-form PUMA solver, which does not apply here (" +
                  choice.not_closed_form +
                  "); leave the configuration free to take the nearest solution";
    return goal;
  }
  const core::IkResult result = core::SolveIk(model, request.target, reference, ik_request);
  if (!result.ok()) {
    goal.reason = std::string(core::IkFailureName(result.failure)) + ": " + result.reason;
    return goal;
  }
  // Solutions come within-limits first, each group nearest the reference first.
  for (const core::IkSolution& solution : result.solutions) {
    if (!solution.within_limits) break;
    if (request.HasConfig() && !(solution.config && request.Matches(*solution.config))) continue;
    goal.ok = true;
    goal.q = solution.q;
    goal.config_name = solution.config ? solution.config->Name() : "";
    return goal;
  }
  goal.reason =
      "configuration " + request.ConfigName() + " has no solution inside the joint limits";
  return goal;
}

}  // namespace sirupp::control
