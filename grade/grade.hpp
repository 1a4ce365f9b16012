#pragma once
// `sirupp grade`: every task of a suite for a student's controller and for the baseline (the
// built-in PIC-SERVO PID with the model's gains, the paper's Kp 100, Kd 1000, Ki 0), `jobs` tasks
// at a time, each on its own private bus; then the figures, the pass checks and the score (the
// share of tasks passed, in %). Outputs (grade/report.hpp): report.md, results.json, plots.
// A class at once: GradeBatch grades each sub-folder of a directory (docs/grading.md).

#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "grade/metrics.hpp"
#include "grade/runner.hpp"
#include "grade/suite.hpp"

namespace sirupp::grade {

struct TaskResult {
  std::string task;
  TaskRecord record;  // empty when it ended early
  TaskMetrics metrics;
  bool passed = false;
  // "" when it ran; else why it ended early (a crash, a hang, NaN, never answered, a fault).
  std::string ended;
};

struct ControllerResult {
  std::string label;
  std::vector<TaskResult> tasks;  // in suite order
  int passed() const;
  double score() const;  // % of tasks passed
  std::vector<std::string> FailedTasks() const;
};

struct GradeOptions {
  int jobs = 1;
  bool baseline = true;
  std::string bin_dir;   // where sirupp-sim and sirupp-control are
  std::string work_dir;  // task logs: WORK/CONTROLLER_TASK/
  // Task ports come from [port_base, port_base + kPortCount), each held with a PortLease
  // (grade/port_lease.hpp) while its task runs; 0 = kPortBase. Lock files in port_lock_dir
  // ("" = the system's).
  int port_base = 0;
  std::string port_lock_dir;
};
inline constexpr int kPortBase = 20000;
inline constexpr int kPortCount = 10000;

// Runs `controllers` (each over the whole suite) with `jobs` tasks at a time; the results are in
// the same order whatever `jobs` is. Tasks of one controller stop early (each listed as not run)
// once sirupp-control refuses to load its library.
std::vector<ControllerResult> RunControllers(const Suite& suite, const core::RobotModel& model,
                                             const std::vector<ControllerSpec>& controllers,
                                             const GradeOptions& options);

// The baseline's label.
extern const char* const kBaselineLabel;

}  // namespace sirupp::grade
