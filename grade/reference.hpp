#pragma once
// What each controller is given to follow, tick by tick, on every task of a suite: the reference.
//
// A controller library and the baseline run inside sirupp-control and get its profile generators'
// set-points each tick (State::setpoint_* in include/sirupp/controller.h, ARM_SETPOINT). A process
// controller takes sirupp-control's place, so the grader computes the same set-points before the
// task starts and hands them over as a file ({reference_csv}, docs/grading.md): one design, the
// same reference for every kind of controller, and every controller is measured against it.
//
// - plan, step and hold tasks: sirupp-control's own sequencer and chip model (control::Sequencer
//   over control::ServoBank) run the task's plan on an arm that follows its set-points exactly,
//   started as the grader starts sirupp-control (tick 0 at the start pose, the plan taken before
//   tick 1). The trapezoidal profiles do not depend on where the arm is, so these are the
//   set-points sirupp-control makes in the run (test_grade_runner compares them with the
//   baseline's ARM_SETPOINT, tick by tick);
// - track tasks: the smooth path itself on every joint (a joint the path does not move holds its
//   start), the reference every controller is measured against there.

#include <cstddef>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "grade/suite.hpp"

namespace sirupp::grade {

// One joint at one tick, SI (rad or m, per s, per s^2).
struct ReferencePoint {
  double position = 0;
  double velocity = 0;
  double acceleration = 0;
  double goal = 0;  // where the joint's present move ends (a track task: the task's goal)
};

// Rows 0..ticks-1, num_joints points each.
class ReferenceTable {
 public:
  ReferenceTable(size_t ticks, size_t num_joints)
      : num_joints_(num_joints), points_(ticks * num_joints) {}
  size_t ticks() const { return num_joints_ == 0 ? 0 : points_.size() / num_joints_; }
  size_t num_joints() const { return num_joints_; }
  ReferencePoint& At(size_t tick, size_t joint) { return points_[tick * num_joints_ + joint]; }
  const ReferencePoint& At(size_t tick, size_t joint) const {
    return points_[tick * num_joints_ + joint];
  }

 private:
  size_t num_joints_;
  std::vector<ReferencePoint> points_;
};

// sirupp-control's set-points for the task's plan on ticks 0..ticks-1 (above). Throws
// std::runtime_error with the sequencer's words if the plan is refused or faults.
ReferenceTable ChipProfile(const core::RobotModel& model, const Task& task, size_t ticks);

// The reference of the task (the path on a track task, else ChipProfile).
ReferenceTable TaskReference(const core::RobotModel& model, const Task& task, size_t ticks);

// The reference as a process controller gets it ({reference_csv}, docs/grading.md): a header line,
// then one row per tick: tick, time_s, then per joint position (deg or mm), velocity (deg/s or
// mm/s) and acceleration (deg/s^2 or mm/s^2). Throws core::ConfigError naming the file if it
// cannot be written.
void WriteReferenceCsv(const std::string& file, const core::RobotModel& model,
                       const ReferenceTable& table);

}  // namespace sirupp::grade
