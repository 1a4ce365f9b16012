#include "control/plan_collision.hpp"

#include <cstdio>

#include "control/plan_trace.hpp"
#include "core/units.hpp"

namespace sirupp::control {

PlanCollisionReport CheckPlanCollisions(const core::RobotModel& model, const Plan& plan,
                                        const std::vector<double>& start,
                                        planning::CollisionModel& collision, double step_rad) {
  planning::SetpointSweep sweep(collision, step_rad);
  PlanCollisionReport report;
  report.error = sweep.Feed(core::ToJointVector(start), 0, -1, true);
  int previous_step = -1;
  core::JointVector last;
  double last_time = 0;
  if (!report.error) {
    const TraceSummary summary =
        TracePlanSetpoints(model, plan, start,
                           [&](int step_index, const std::vector<double>& setpoint, double time_s) {
                             const core::JointVector q = core::ToJointVector(setpoint);
                             // The end of each move (a new one started) is checked whatever the
                             // step.
                             if (step_index != previous_step && last.size() > 0) {
                               report.error = sweep.Feed(last, last_time, previous_step, true);
                               if (report.error) return false;
                             }
                             previous_step = step_index;
                             last = q;
                             last_time = time_s;
                             report.error = sweep.Feed(q, time_s, step_index);
                             return !report.error.has_value();
                           });
    report.duration_s = summary.duration_s;
    if (!report.error && last.size() > 0) {
      report.error = sweep.Feed(last, summary.duration_s, previous_step, true);
    }
  }
  for (const planning::SweepFinding& f : sweep.free_touches()) {
    if (!report.error || f.time_s <= report.error->time_s) report.free_touches.push_back(f);
  }
  if (report.error) report.duration_s = report.error->time_s;
  report.states_checked = sweep.states_checked();
  return report;
}

std::string JointsText(const core::RobotModel& model, const core::JointVector& q) {
  std::string out;
  for (int j = 0; j < q.size(); ++j) {
    const bool revolute = model.joints[static_cast<size_t>(j)].type == core::JointType::kRevolute;
    char text[32];
    std::snprintf(text, sizeof text, "%.2f", revolute ? q[j] / kDeg : q[j]);
    out += (j > 0 ? " " : "") + std::string(text);
  }
  return out;
}

std::string FindingPlace(const Plan& plan, const planning::SweepFinding& finding) {
  if (finding.step < 0) return plan.name + ": at the start";
  const PlanStep& step = plan.steps[static_cast<size_t>(finding.step)];
  return plan.name + ":" + std::to_string(step.line) + ": " + step.text;
}

std::string FindingDetail(const core::RobotModel& model, const planning::CollisionModel& collision,
                          const planning::SweepFinding& finding) {
  char time[32];
  std::snprintf(time, sizeof time, "%.3f", finding.time_s);
  return collision.Describe(finding.contact) + "; joints [" + JointsText(model, finding.state) +
         "] deg, " + time + " s into the plan";
}

std::string FindingError(const core::RobotModel& model, const Plan& plan,
                         const planning::CollisionModel& collision,
                         const planning::SweepFinding& finding) {
  return FindingPlace(plan, finding) + ": " +
         (finding.contact.kind == planning::ContactKind::kSelf ? "the arm hits itself: "
                                                               : "collision: ") +
         FindingDetail(model, collision, finding);
}

}  // namespace sirupp::control
