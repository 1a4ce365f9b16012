#pragma once
// Runs one task of a suite for one controller, on a private bus, and records it tick by tick.
//
// Processes: sirupp-sim in lockstep (with the task's start pose, duration and arm change) and the
// controller: sirupp-control with the PIC-SERVO PID (the baseline) or with the student's library
// (run by sirupp-control in its own host process), or the student's own process. The grader
// itself is the second lockstep participant: it answers every state (with the task's disturbance
// torque, zero otherwise), so it sees every tick before the sim steps, and it holds tick 0 until
// sirupp-control has taken the task's plan. Every task gets its own LCM URL (udpm with its own
// port and ttl=0), so no task can hear another.
//
// A task ends early, with a reason, when the controller crashes, hangs past the per-tick limit,
// never answers, returns a non-finite effort, faults (sirupp-control names the cause) or refuses
// the plan, or when the task takes longer than the per-task limit.

#include <cstdint>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "grade/suite.hpp"

namespace sirupp::grade {

struct ControllerSpec {
  enum class Kind { kBaseline, kLibrary, kProcess };
  Kind kind = Kind::kBaseline;
  std::string label;                 // for reports: "baseline", "pd_gravity.so", "java JointPid"
  std::string library;               // kLibrary
  std::string args;                  // kLibrary: --controller-args
  bool sandbox = true;               // kLibrary: false = sirupp-control --no-sandbox
  std::vector<std::string> command;  // kProcess, with placeholders (docs/grading.md)
};

// The process command with its placeholders filled: {url}, {name} (the participant name),
// {goal_deg} and {start_deg} (one word per joint), {duration_s}, {reference_csv} (the file
// `reference_file`, written by RunTask when the command uses it: the task's reference, the
// set-points a library gets, grade/reference.hpp).
std::vector<std::string> ExpandCommand(const std::vector<std::string>& command,
                                       const core::RobotModel& model, const Task& task,
                                       const std::string& url, const std::string& name,
                                       const std::string& reference_file = "");

struct RunOptions {
  std::string bin_dir;   // sirupp-sim, sirupp-control
  std::string work_dir;  // logs of this task's processes go here
  int port = 0;          // the task's private udpm port (a PortLease's): proc::RigUrl
};

// One task as recorded: row k is tick k. Positions and references in rad (m), efforts N*m (N).
struct TaskRecord {
  bool completed = false;  // ran its whole duration
  std::string failure;     // why it ended early ("" when completed)
  int num_joints = 0;
  double tick_s = 0;
  // The reference is a profile the controller was given: sirupp-control's set-points (the same
  // set-points computed before the task for a process controller, grade/reference.hpp), or a
  // tracking task's path (for every controller). RunTask always gives one.
  bool has_reference = false;
  // A tracking task: the reference is a path that may swing past the final goal, so the step
  // figures look only at the end (grade/metrics.hpp).
  bool track = false;
  std::vector<double> time_s;     // per tick
  std::vector<double> position;   // tick-major, num_joints per tick
  std::vector<double> reference;  // set-point position (or the path)
  std::vector<double> goal;       // the goal of the present move (or the task's goal)
  std::vector<double> effort;     // the controller's effort, after the limits
  int64_t missing_rows = 0;       // ticks without the controller's answer or set-point heard
  // A tracking task run by sirupp-control: the largest |chip set-point - path| on the tracked
  // joints (rad or m), how closely the chip's profile followed the path it was handed.
  double setpoint_deviation = 0;
  size_t ticks() const { return time_s.size(); }
};

TaskRecord RunTask(const Suite& suite, const core::RobotModel& model, const Task& task,
                   const ControllerSpec& controller, const RunOptions& options);

}  // namespace sirupp::grade
