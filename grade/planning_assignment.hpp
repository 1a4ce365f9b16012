#pragma once
// A planning assignment for `sirupp grade` (docs/grading.md, "Planning assignments"): a suite of
// format sirupp-grade-planning-1 (config/grading/planning.yaml) lists start/goal queries in one
// environment; the student's code is a Python file with `plan(start, goal, scene) -> path` (a
// k x n array, rad), or a C++ library exporting sirupp_plan (include/sirupp/student_planner.h;
// its source is built first by BuildController, as a controller's is). For each query the grader
//   1. runs the planner in the sandbox, within the suite's wall-time limit, with the model and
//      the environment read-only and the task folder writable: a Python function through
//      python/sirupp/plan_host.py under Debian's python3 with this build's module, given a
//      sirupp.Scene of the suite's environment (padded by `student_padding_m`); a library through
//      sirupp-planner-host (grade/planner_host.hpp), given a sirupp_planning_scene served from
//      the same collision model with the same padding. Both write the path to the same file;
//   2. checks the path with its own collision model (planning/collision_model.hpp, padded by
//      `check.padding_m`) at its own, finer resolution (`check.step_rad`): every value finite,
//      the first waypoint at the start and the last at the goal (within `check.endpoint_deg`),
//      every waypoint within the soft limits (what sirupp-control accepts), every segment free of
//      static objects, free objects and the arm itself; a failure names the waypoint or segment,
//      where along it, the link and the object;
//   3. plans the same query with OMPL (the suite's `reference` request) for the comparison;
//   4. runs a path that passed on a rig (grade/runner.hpp: sirupp-sim in lockstep with the
//      environment, sirupp-control with the PIC-SERVO PID, the path as a plan through
//      planning/plan_text.hpp) and checks every recorded tick for contact and the end at the goal.
// Reads the suite, the model, the environment and the student's file; writes the task folders
// (the student's path, logs) and, through WritePlanningReport, report.md and results.json.

#include <cstdint>
#include <string>
#include <vector>

#include "core/kinematics.hpp"
#include "core/robot_model.hpp"
#include "planning/planner.hpp"

namespace sirupp::grade {

inline constexpr const char* kPlanningSuiteFormat = "sirupp-grade-planning-1";

struct PlanningQuery {
  std::string name;
  int line = 0;
  core::JointVector start, goal;  // rad (m)
};

struct PlanningSuite {
  std::string file, name, description;
  std::string model_file, environment_file;  // as resolved
  double student_padding_m = 0.01;           // the Scene the student's function gets
  double check_step_rad = 0.002;             // the grader's own edge resolution
  double check_padding_m = 0.0;              // the grader's own padding
  double endpoint_rad = 0.001;               // first / last waypoint from start / goal, at most
  double end_error_rad = 0.035;              // the arm in the sim at the goal, at most (2 deg)
  double plan_s = 60;                        // wall seconds for one call of the function
  planning::PlanRequest reference;           // OMPL's plan of each query, for the comparison
  std::vector<PlanningQuery> queries;
};

// The format of a suite file (its top-level `format:` line: "sirupp-grade-suite-1",
// kPlanningSuiteFormat, or "" when it has none), so `sirupp grade` knows which reader to use.
// Throws core::ConfigError for a file that cannot be read.
std::string SuiteFormat(const std::string& file);

// Reads a planning suite strictly: core::ConfigError "file:line:col: key: problem" for anything
// unknown, missing or out of range, including a start or goal that is outside the limits or
// touches something (naming the link and the object).
PlanningSuite LoadPlanningSuite(const std::string& file,
                                std::string (*resolve)(const std::string&));
PlanningSuite ParsePlanningSuite(const std::string& text, const std::string& name,
                                 std::string (*resolve)(const std::string&));

struct PlanningQueryResult {
  std::string query;
  bool passed = false;
  std::string problem;  // the first problem found ("" when passed)
  // The student's function.
  bool returned = false;
  double student_s = 0;  // its own time inside the function (wall s)
  std::vector<core::JointVector> path;
  double length_rad = 0;        // joint-space length
  double duration_s = 0;        // the plan's duration (planning/plan_text.hpp's segments)
  uint64_t states_checked = 0;  // by the grader's check
  // OMPL's reference on the same query.
  bool reference_solved = false;
  double reference_s = 0, reference_length_rad = 0, reference_duration_s = 0;
  // The run on the rig (when the path passed the check).
  bool ran = false;
  int64_t ticks = 0;
  int64_t touching_ticks = 0;  // recorded ticks where the arm touches anything
  double end_error_rad = 0;    // largest joint error at the last tick
};

struct PlanningResult {
  std::string label;  // the student's file name
  std::vector<PlanningQueryResult> queries;
  int passed() const;
  double score() const;  // % of queries passed
};

struct PlanningGradeOptions {
  std::string bin_dir;     // sirupp-sim, sirupp-control, sirupp-planner-host; ../python: the module
  std::string label;       // the submission's name in the reports ("": the student file's name)
  std::string work_dir;    // WORK/QUERY/: the student's path, logs
  bool sandbox = true;     // false: the function runs unconfined (own code only)
  bool run_on_rig = true;  // false: check only (tests of the check)
  int port_base = 0;       // 0 = kPortBase (grade.hpp)
  std::string port_lock_dir;
};

// Grades `student_file` (a .py with plan(start, goal, scene), or a .so exporting sirupp_plan)
// on every query, in suite order. Whatever the planner does (crash, hang, garbage), a query
// fails with one line and the grade goes on.
PlanningResult GradePlanning(const PlanningSuite& suite, const core::RobotModel& model,
                             const std::string& student_file, const PlanningGradeOptions& options);

// The check of step 2 alone: "" when the path passes, else the first problem.
std::string CheckStudentPath(const PlanningSuite& suite, planning::CollisionModel& check,
                             const PlanningQuery& query,
                             const std::vector<core::JointVector>& path);

// report.md and results.json (no times or paths: the same submission gives the same file) in
// `out_dir`; returns results.json's FNV-1a hash. SummaryLine: one line for the terminal.
std::string WritePlanningReport(const std::string& out_dir, const PlanningSuite& suite,
                                const core::RobotModel& model, const PlanningResult& result);
std::string PlanningSummaryLine(const PlanningSuite& suite, const PlanningResult& result,
                                const std::string& hash);

}  // namespace sirupp::grade
