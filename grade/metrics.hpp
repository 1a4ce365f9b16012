#pragma once
// The figures of one graded task, per joint, from its record, and the pass check against the
// task's thresholds. Definitions (docs/grading.md):
//  - the step: from where the joint was when its last move started (the last change of its goal)
//    to the final goal; a joint "moves" when the step is at least 0.5 deg (0.5 mm);
//  - rise time: 10 % to 90 % of the step; settling time: from the end of the
//    reference's motion (the profile's end; the move's start for a process controller) until the
//    joint stays within max(2 % of the step, 0.1 deg) of the goal; overshoot: the largest excursion
//    past the goal, % of the step (only joints that move); on a tracking task, whose path may
//    swing past the goal on its way, no rise time and the overshoot only after the path's end;
//  - steady-state error: mean |goal - position| over the task's last 0.1 s (every joint);
//  - tracking error: position - reference (the profile set-point the controller was given; the
//    goal for a process controller), RMS and max over the task;
//  - effort (the controller's own, after the limits): peak |u|, RMS, time saturated (|u| at its
//    limit), smoothness: RMS of du/dt.
// Positions in deg (mm for prismatic joints), efforts N*m (N).

#include <optional>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "grade/runner.hpp"
#include "grade/suite.hpp"

namespace sirupp::grade {

struct JointMetrics {
  bool moves = false;
  double step = 0;                                              // deg (mm), signed
  std::optional<double> rise_s, settling_s, overshoot_percent;  // nullopt: not reached / n/a
  double steady_state = 0;                                      // deg (mm)
  double rms_tracking = 0, max_tracking = 0;                    // deg (mm)
  double peak_effort = 0, rms_effort = 0;                       // N*m (N)
  double saturated_s = 0;
  double effort_rate_rms = 0;  // N*m/s (N/s)
};

struct TaskMetrics {
  std::vector<JointMetrics> joints;
  std::vector<std::string> failed_checks;  // "joint 2: settling 1.8 s > 1.5 s"
  bool passed() const { return failed_checks.empty(); }
  // The joint (0-based) with the largest RMS tracking error: the one plotted.
  int worst_joint = 0;
};

TaskMetrics ComputeMetrics(const core::RobotModel& model, const TaskRecord& record,
                           const Thresholds& pass);

}  // namespace sirupp::grade
