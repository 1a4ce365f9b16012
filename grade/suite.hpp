#pragma once
// A grading suite (config/grading/*.yaml, format in docs/grading.md): a list of tasks, each with
// a start pose, what is commanded (one of the paper's plans, a joint step, a hold, a path to
// track), a change to the simulated arm (payload on the flange, friction scaled, gravity off), an
// optional disturbance torque, a duration and pass thresholds. Read strictly (core/yaml_reader):
// every problem is one ConfigError naming file:line:column, the key path, the bad value and what
// is allowed (tests/test_grade_suite.cpp has a case per rule). Plans are validated against the
// model when the suite is loaded, so a bad suite stops before any process starts.

#include <optional>
#include <string>
#include <vector>

#include "core/robot_model.hpp"
#include "grade/trajectory.hpp"
#include "sim/model_change.hpp"

namespace sirupp::grade {

// Pass thresholds, each optional (absent: not checked). Applied to every joint; the step figures
// (rise, settling, overshoot) only to joints the task moves.
struct Thresholds {
  std::optional<double> rise_s;
  std::optional<double> settling_s;
  std::optional<double> overshoot_percent;
  std::optional<double> steady_state_deg;
  std::optional<double> rms_tracking_deg;
  std::optional<double> max_tracking_deg;
  std::optional<double> saturated_s;
};

// A torque added to one joint's effort by a second lockstep participant (the grader itself)
// while from_s <= t < to_s.
struct Disturbance {
  int joint = 0;      // 0-based
  double effort = 0;  // N*m (N for a prismatic joint)
  double from_s = 0, to_s = 0;
};

// A tracking task's path (grade/trajectory.hpp), every joint: one joint back and forth on
// minimum-jerk legs (the others holding their start), or several joints at once on a spline
// through waypoints.
struct Track {
  std::string shape;  // "back_and_forth" or "spline"
  Path path;
};

struct Task {
  std::string name;
  int line = 0;               // where the task starts in the suite file
  std::string kind;           // "plan", "step", "hold" or "track"
  std::string description;    // one line for the report, e.g. "plan config/plans/set1.plan"
  std::string plan_name;      // the name the plan runs under (ARM_PLAN)
  std::string plan_text;      // what sirupp-control runs (generated for step, hold and track)
  std::vector<double> start;  // rad or m, one per joint
  std::vector<double> goal;   // where the plan leaves each joint, rad or m
  double duration_s = 0;      // simulated time
  sim::ModelChange arm;       // the simulated arm's change
  std::optional<Disturbance> disturbance;
  std::optional<Track> track;  // kind "track"
  Thresholds pass;
  // sirupp-sim's --environment (a planning assignment's run, grade/planning_assignment.hpp);
  // "" = none (every suite task).
  std::string environment;
};

struct Limits {
  double tick_s = 2;    // wall seconds a controller may take for one tick
  double start_s = 30;  // wall seconds until the controller answers its first tick
  double task_s = 300;  // wall seconds for a whole task
};

struct Suite {
  std::string file;
  std::string name;
  std::string description;
  std::string model_file;   // as resolved
  std::string source_hash;  // FNV-1a of the suite file's bytes
  Limits limits;
  std::vector<Task> tasks;
};

// Reads and validates `file` (plans and models are resolved with tools::ResolveDataPath-style
// paths by the caller: `resolve` maps a path written in the suite to a readable one).
Suite LoadSuite(const std::string& file, std::string (*resolve)(const std::string&));
// The same from text (tests); `name` stands for the file in messages.
Suite ParseSuite(const std::string& text, const std::string& name,
                 std::string (*resolve)(const std::string&));

}  // namespace sirupp::grade
