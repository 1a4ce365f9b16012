#include "grade/planning_assignment.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/model_loader.hpp"
#include "core/motion_limits.hpp"
#include "core/signal_name.hpp"
#include "core/yaml_reader.hpp"
#include "grade/child.hpp"
#include "grade/grade.hpp"
#include "grade/planner_host.hpp"
#include "grade/port_lease.hpp"
#include "grade/runner.hpp"
#include "planning/collision_model.hpp"
#include "planning/plan_text.hpp"
#include "sandbox/sandbox.hpp"

namespace sirupp::grade {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;
constexpr double kPi = 3.14159265358979323846;
constexpr size_t kMaxWaypoints = kMaxPlanWaypoints;

std::string Num(double value) { return core::FormatNumber(value); }
std::string Approx(double value) { return core::FormatApprox(value); }

// Degrees (mm) as written in suites to SI, one per joint, within the limits.
core::JointVector ReadPose(const core::YamlMap& map, const std::string& key,
                           const core::RobotModel& model) {
  const size_t n = static_cast<size_t>(model.num_joints());
  const core::YamlValue value = map.Get(key, std::to_string(n) + " numbers (deg, mm)");
  const std::vector<double> deg = value.Numbers(n, core::AnyNumber("deg, mm for prismatic joints"));
  core::JointVector q(static_cast<Eigen::Index>(n));
  for (size_t j = 0; j < n; ++j) {
    const bool revolute = model.joints[j].type == core::JointType::kRevolute;
    q[static_cast<Eigen::Index>(j)] = revolute ? deg[j] * kPi / 180 : deg[j] / 1000;
  }
  return q;
}

// The pose of a joint vector in the suite's units, for messages.
std::string Degrees(const core::RobotModel& model, const core::JointVector& q) {
  std::string out;
  for (int j = 0; j < q.size(); ++j) {
    const bool revolute = model.joints[static_cast<size_t>(j)].type == core::JointType::kRevolute;
    out += (j ? " " : "") + Approx(revolute ? q[j] * 180 / kPi : q[j] * 1000);
  }
  return out;
}

double PlanDuration(const core::RobotModel& model, const std::vector<core::JointVector>& path) {
  double duration = 0;
  for (size_t i = 1; i < path.size(); ++i) {
    duration += planning::SegmentDuration(model, path[i - 1], path[i]);
  }
  return duration;
}

bool EndsWith(const std::string& text, const std::string& end) {
  return text.size() >= end.size() && text.compare(text.size() - end.size(), end.size(), end) == 0;
}

// The student's path as plan_host.py and sirupp-planner-host write it: "# seconds S" then one
// line of n numbers (rad) per waypoint; nan and inf are read as such, for the check to name.
// "" or the problem.
std::string ReadPath(const std::string& file, int n, std::vector<core::JointVector>& path,
                     double& seconds) {
  std::ifstream in(file);
  if (!in) return "the planner wrote no path (see its log)";
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.rfind("# seconds ", 0) == 0) {
      seconds = std::atof(line.c_str() + 10);
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    core::JointVector q(n);
    std::string word;
    for (int j = 0; j < n; ++j) {
      char* end = nullptr;
      if (words >> word) q[j] = std::strtod(word.c_str(), &end);
      if (end == nullptr || end != word.c_str() + word.size()) {
        return "path line " + std::to_string(number) + ": not " + std::to_string(n) + " numbers";
      }
    }
    path.push_back(q);
    if (path.size() > kMaxWaypoints) {
      return "more than " + std::to_string(kMaxWaypoints) + " waypoints";
    }
  }
  if (path.empty()) return "the planner returned an empty path";
  return "";
}

// How the planner's process ended, a crash named by its signal also through the sandbox (bwrap
// reports it as exit code 128 + N).
std::string HowPlannerEnded(const Child& child, bool sandboxed) {
  const int status = sandboxed ? sandbox::UnwrapStatus(child.status()) : child.status();
  if (WIFSIGNALED(status)) return "crashed with " + core::SignalDescription(WTERMSIG(status));
  return child.HowEnded();
}

// The student's planner, in the sandbox unless options.sandbox is off: a Python file's plan()
// through python/sirupp/plan_host.py, a library's sirupp_plan through sirupp-planner-host
// (grade/planner_host.hpp). "" or why it failed.
std::string RunStudent(const PlanningSuite& suite, const core::RobotModel& model,
                       const PlanningQuery& query, const std::string& student_file,
                       const PlanningGradeOptions& options, const std::string& dir,
                       PlanningQueryResult& result) {
  const std::string out_file = (fs::path(dir) / "path.txt").string();
  fs::remove(out_file);  // not an earlier grade's
  const bool python = EndsWith(student_file, ".py");
  const fs::path module_dir = fs::weakly_canonical(fs::path(options.bin_dir) / ".." / "python");
  std::string host;
  std::vector<std::string> argv;
  if (python) {
    host = (module_dir / "sirupp" / "plan_host.py").string();
    argv = {"/usr/bin/python3", "-I", host};
  } else if (EndsWith(student_file, ".so")) {
    host = (fs::absolute(options.bin_dir) / "sirupp-planner-host").lexically_normal().string();
    argv = {host};
  } else {
    return "the planner '" + student_file +
           "': allowed a Python file (.py) or a library (.so; its C++ source is built first)";
  }
  if (!fs::is_regular_file(host)) return "the planning host " + host + " is missing (build it)";
  argv.insert(argv.end(),
              {fs::absolute(student_file).string(), fs::absolute(suite.model_file).string(),
               fs::absolute(suite.environment_file).string(), Num(suite.student_padding_m)});
  if (!python) argv.push_back(Num(suite.plan_s));
  argv.push_back(out_file);
  for (int j = 0; j < query.start.size(); ++j) argv.push_back(Num(query.start[j]));
  for (int j = 0; j < query.goal.size(); ++j) argv.push_back(Num(query.goal[j]));
  if (options.sandbox) {
    sandbox::Policy policy;
    policy.limits.cpu_s = suite.plan_s + 5;
    policy.read_only = {fs::absolute(student_file).string(),
                        fs::absolute(suite.model_file).string(),
                        fs::absolute(suite.environment_file).string()};
    if (python) policy.read_only.push_back(module_dir.string());
    policy.read_write = {fs::absolute(dir).string()};
    policy.chdir = fs::absolute(dir).string();
    try {
      argv = sandbox::Wrap(policy, argv);
    } catch (const std::runtime_error& error) {
      return std::string("the sandbox cannot be had: ") + error.what() + " (docs/sandbox.md)";
    }
  }
  Child child;
  const std::string log = (fs::path(dir) / "student.log").string();
  try {
    child.Start(argv, log);
  } catch (const std::exception& error) {
    return error.what();
  }
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(suite.plan_s + 10);
  while (child.Running()) {
    if (std::chrono::steady_clock::now() > deadline) {
      child.Stop(1.0);
      return "the planner did not return within " + Num(suite.plan_s) + " s";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!child.EndedCleanly()) {
    const std::string how = HowPlannerEnded(child, options.sandbox);
    const std::string tail = child.LogTail(3);
    // Exit code 1: both hosts' own line says what went wrong (after the planner's own output).
    if (how == "exit code 1" && !tail.empty()) return tail;
    return "the planner failed (" + how + ")" + (tail.empty() ? "" : ": " + tail);
  }
  std::vector<core::JointVector> path;
  double seconds = 0;
  const std::string problem = ReadPath(out_file, model.num_joints(), path, seconds);
  if (!problem.empty()) return problem;
  result.returned = true;
  result.student_s = seconds;
  result.path = std::move(path);
  return "";
}

// Runs the checked path on a rig: the sim with the environment, the PIC-SERVO PID. "" or why not.
std::string RunOnRig(const PlanningSuite& suite, const core::RobotModel& model,
                     const PlanningQuery& query, const PlanningGradeOptions& options,
                     const std::string& dir, size_t index, PlanningQueryResult& result) {
  Suite rig_suite;
  rig_suite.file = suite.file;
  rig_suite.name = suite.name;
  rig_suite.model_file = suite.model_file;
  Task task;
  task.name = query.name;
  task.line = query.line;
  task.kind = "plan";
  task.description = "the student's path for " + query.name;
  task.plan_name = query.name + ".plan";
  planning::PlanTextOptions text;
  text.move_to_start = false;  // the sim starts at the query's start
  text.comments = {"the student's path for " + query.name + " (sirupp grade)"};
  task.plan_text = planning::PathToPlanText(model, result.path, text);
  task.start.assign(query.start.data(), query.start.data() + query.start.size());
  task.goal.assign(query.goal.data(), query.goal.data() + query.goal.size());
  task.duration_s = result.duration_s + 1.0;
  task.environment = suite.environment_file;
  RunOptions run;
  run.bin_dir = options.bin_dir;
  run.work_dir = dir;
  PortLease lease;
  try {
    lease = PortLease::Acquire(options.port_base ? options.port_base : kPortBase, kPortCount,
                               static_cast<int>(index), options.port_lock_dir);
  } catch (const std::exception& error) {
    return error.what();
  }
  run.port = lease.port();
  ControllerSpec baseline;
  baseline.kind = ControllerSpec::Kind::kBaseline;
  baseline.label = kBaselineLabel;
  const TaskRecord record = RunTask(rig_suite, model, task, baseline, run);
  lease.Release();
  if (!record.completed) return "the run on the rig ended early: " + record.failure;
  result.ran = true;
  result.ticks = static_cast<int64_t>(record.ticks());
  // The arm as the sim moved it, against the environment unpadded (the sim's own shapes).
  const core::Environment environment = core::LoadEnvironment(suite.environment_file);
  planning::CollisionModel exact(model, environment, planning::CollisionOptions{});
  const int n = record.num_joints;
  std::string first;
  for (size_t k = 0; k < record.ticks(); ++k) {
    const core::JointVector q =
        Eigen::Map<const core::JointVector>(record.position.data() + k * static_cast<size_t>(n), n);
    if (auto contact = exact.FirstContact(q)) {
      ++result.touching_ticks;
      if (first.empty()) {
        first = "in the sim at " + Approx(record.time_s[k]) + " s: " + exact.Describe(*contact);
      }
    }
  }
  const size_t last = record.ticks() - 1;
  for (int j = 0; j < n; ++j) {
    result.end_error_rad =
        std::max(result.end_error_rad,
                 std::abs(record.position[last * static_cast<size_t>(n) + static_cast<size_t>(j)] -
                          query.goal[j]));
  }
  if (!first.empty()) return first;
  if (result.end_error_rad > suite.end_error_rad) {
    return "in the sim the arm ends " + Approx(result.end_error_rad * 180 / kPi) +
           " deg from the goal (allowed " + Approx(suite.end_error_rad * 180 / kPi) + ")";
  }
  return "";
}

}  // namespace

std::string SuiteFormat(const std::string& file) {
  // The top-level `format:` line (both formats write it so; the readers check it strictly).
  std::istringstream lines(core::ReadTextFile(file));
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("format:", 0) != 0) continue;
    std::string value = line.substr(7);
    const size_t comment = value.find('#');
    if (comment != std::string::npos) value.resize(comment);
    const size_t first = value.find_first_not_of(" \t\"'");
    const size_t last = value.find_last_not_of(" \t\r\"'");
    return first == std::string::npos ? "" : value.substr(first, last - first + 1);
  }
  return "";
}

PlanningSuite ParsePlanningSuite(const std::string& text, const std::string& name,
                                 std::string (*resolve)(const std::string&)) {
  const core::YamlDocument document = core::YamlDocument::Parse(text, name);
  const core::YamlMap map =
      document.Root().Map({"format", "name", "description", "model", "environment",
                           "student_padding_m", "check", "limits", "reference", "queries"});
  const core::YamlValue format = map.Get("format", kPlanningSuiteFormat);
  if (format.String() != kPlanningSuiteFormat) {
    format.Fail("format '" + format.String() + "': allowed " + kPlanningSuiteFormat);
  }
  PlanningSuite suite;
  suite.file = name;
  suite.name = map.String("name");
  suite.description = map.StringOr("description", "");
  suite.model_file = resolve(map.StringOr("model", "config/robots/puma260.yaml"));
  const core::RobotModel model = core::LoadRobotModel(suite.model_file);
  suite.environment_file = resolve(map.String("environment"));
  const core::Environment environment = core::LoadEnvironment(suite.environment_file);
  suite.student_padding_m =
      map.NumberOr("student_padding_m", suite.student_padding_m, core::NumberInRange(0, 0.1, "m"));
  if (map.Has("check")) {
    const core::YamlMap check =
        map.Get("check", "a mapping")
            .Map({"step_rad", "padding_m", "endpoint_deg", "end_error_deg"});
    suite.check_step_rad =
        check.NumberOr("step_rad", suite.check_step_rad, core::NumberInRange(1e-4, 0.05, "rad"));
    suite.check_padding_m =
        check.NumberOr("padding_m", suite.check_padding_m, core::NumberInRange(0, 0.1, "m"));
    suite.endpoint_rad = check.NumberOr("endpoint_deg", suite.endpoint_rad * 180 / kPi,
                                        core::NumberInRange(1e-6, 5, "deg")) *
                         kPi / 180;
    suite.end_error_rad = check.NumberOr("end_error_deg", suite.end_error_rad * 180 / kPi,
                                         core::NumberInRange(0.01, 20, "deg")) *
                          kPi / 180;
  }
  if (map.Has("limits")) {
    const core::YamlMap limits = map.Get("limits", "a mapping").Map({"plan_s"});
    suite.plan_s = limits.NumberOr("plan_s", suite.plan_s, core::NumberInRange(1, 600, "s"));
  }
  if (map.Has("reference")) {
    const core::YamlMap reference =
        map.Get("reference", "a mapping").Map({"planner", "seed", "time_s"});
    if (reference.Has("planner")) {
      suite.reference.planner = reference.Get("planner", "").Choice(planning::PlannerNames());
    }
    if (reference.Has("seed")) {
      suite.reference.seed =
          static_cast<uint32_t>(reference.Get("seed", "").Integer(0, 4294967295LL));
    }
    suite.reference.time_limit_s =
        reference.NumberOr("time_s", 1.0, core::NumberInRange(0.01, 600, "s"));
  }
  planning::CollisionOptions options;
  options.padding_m = suite.student_padding_m;
  planning::CollisionModel check(model, environment, options);
  const core::YamlValue queries = map.Get("queries", "a list of {name, from_deg, to_deg}");
  for (const core::YamlValue& entry : queries.Sequence(1, 100)) {
    const core::YamlMap q = entry.Map({"name", "from_deg", "to_deg"});
    PlanningQuery query;
    query.name = q.String("name");
    query.line = entry.location().line;
    for (char c : query.name) {
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) {
        q.Get("name", "")
            .Fail("query name '" + query.name +
                  "': allowed letters, digits, '_' and '-' (it names files)");
      }
    }
    for (const PlanningQuery& other : suite.queries) {
      if (other.name == query.name) {
        entry.Fail("query name '" + query.name + "' is used already at line " +
                   std::to_string(other.line));
      }
    }
    query.start = ReadPose(q, "from_deg", model);
    query.goal = ReadPose(q, "to_deg", model);
    if (auto problem = planning::EndpointProblem(check, query.start, "start")) {
      q.Get("from_deg", "").Fail(*problem);
    }
    if (auto problem = planning::EndpointProblem(check, query.goal, "goal")) {
      q.Get("to_deg", "").Fail(*problem);
    }
    suite.queries.push_back(std::move(query));
  }
  return suite;
}

PlanningSuite LoadPlanningSuite(const std::string& file,
                                std::string (*resolve)(const std::string&)) {
  return ParsePlanningSuite(core::ReadTextFile(file), file, resolve);
}

std::string CheckStudentPath(const PlanningSuite& suite, planning::CollisionModel& check,
                             const PlanningQuery& query,
                             const std::vector<core::JointVector>& path) {
  const core::RobotModel& model = check.model();
  const int n = model.num_joints();
  if (path.empty()) return "the path is empty";
  for (size_t i = 0; i < path.size(); ++i) {
    for (int j = 0; j < n; ++j) {
      if (!std::isfinite(path[i][j])) {
        return "waypoint " + std::to_string(i) + ": joint " + std::to_string(j + 1) + " is " +
               Num(path[i][j]);
      }
    }
  }
  const double start_off = (path.front() - query.start).cwiseAbs().maxCoeff();
  if (start_off > suite.endpoint_rad) {
    return "the path starts at [" + Degrees(model, path.front()) + "], not at the start [" +
           Degrees(model, query.start) + "] deg (" + Approx(start_off * 180 / kPi) +
           " deg off; allowed " + Approx(suite.endpoint_rad * 180 / kPi) + ")";
  }
  const double goal_off = (path.back() - query.goal).cwiseAbs().maxCoeff();
  if (goal_off > suite.endpoint_rad) {
    return "the path ends at [" + Degrees(model, path.back()) + "], not at the goal [" +
           Degrees(model, query.goal) + "] deg (" + Approx(goal_off * 180 / kPi) +
           " deg off; allowed " + Approx(suite.endpoint_rad * 180 / kPi) + ")";
  }
  // The soft limits: what sirupp-control accepts in a plan (core/motion_limits.hpp).
  const core::MotionLimits soft = core::DefaultMotionLimits(model);
  for (size_t i = 0; i < path.size(); ++i) {
    for (int j = 0; j < n; ++j) {
      const double lo = core::SoftMin(model, soft, j), hi = core::SoftMax(model, soft, j);
      if (path[i][j] < lo || path[i][j] > hi) {
        return "waypoint " + std::to_string(i) + ": joint " + std::to_string(j + 1) + " at " +
               Approx(path[i][j] * 180 / kPi) + " deg is outside its soft limits [" +
               Approx(lo * 180 / kPi) + ", " + Approx(hi * 180 / kPi) + "] deg";
      }
    }
  }
  if (path.size() == 1) {
    if (auto contact = check.FirstContact(path.front())) return check.Describe(*contact);
    return "";
  }
  for (size_t i = 1; i < path.size(); ++i) {
    const planning::EdgeCheck edge = check.CheckEdge(path[i - 1], path[i], suite.check_step_rad);
    if (!edge.free) {
      return "segment " + std::to_string(i) + " (waypoint " + std::to_string(i - 1) + " to " +
             std::to_string(i) + ") at " + Approx(edge.fraction * 100) + " %, [" +
             Degrees(model, edge.state) +
             "] deg: " + (edge.contact ? check.Describe(*edge.contact) : std::string("touches"));
    }
  }
  return "";
}

int PlanningResult::passed() const {
  int count = 0;
  for (const PlanningQueryResult& q : queries) count += q.passed ? 1 : 0;
  return count;
}

double PlanningResult::score() const {
  return queries.empty() ? 0 : 100.0 * passed() / static_cast<double>(queries.size());
}

PlanningResult GradePlanning(const PlanningSuite& suite, const core::RobotModel& model,
                             const std::string& student_file, const PlanningGradeOptions& options) {
  PlanningResult result;
  result.label = options.label.empty() ? fs::path(student_file).filename().string() : options.label;
  const core::Environment environment = core::LoadEnvironment(suite.environment_file);
  planning::CollisionOptions check_options;
  check_options.padding_m = suite.check_padding_m;
  planning::CollisionModel check(model, environment, check_options);
  planning::CollisionOptions reference_options;
  reference_options.padding_m = suite.student_padding_m;
  planning::CollisionModel reference_model(model, environment, reference_options);
  for (size_t i = 0; i < suite.queries.size(); ++i) {
    const PlanningQuery& query = suite.queries[i];
    PlanningQueryResult q;
    q.query = query.name;
    const std::string dir = (fs::path(options.work_dir) / query.name).string();
    fs::create_directories(dir);
    // OMPL's reference.
    const auto began = std::chrono::steady_clock::now();
    const planning::PlanResult reference =
        planning::PlanPath(reference_model, query.start, query.goal, suite.reference);
    q.reference_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count();
    q.reference_solved = reference.solved;
    if (reference.solved) {
      q.reference_length_rad = reference.length_rad;
      q.reference_duration_s = PlanDuration(model, reference.path);
    }
    q.problem = RunStudent(suite, model, query, student_file, options, dir, q);
    if (q.problem.empty()) {
      q.length_rad = planning::PathLength(q.path);
      const uint64_t before = check.states_checked();
      q.problem = CheckStudentPath(suite, check, query, q.path);
      q.states_checked = check.states_checked() - before;
    }
    if (q.problem.empty()) {
      try {
        q.duration_s = PlanDuration(model, q.path);
        if (options.run_on_rig) q.problem = RunOnRig(suite, model, query, options, dir, i, q);
      } catch (const std::exception& error) {
        q.problem = std::string("the path cannot be run: ") + error.what();
      }
    }
    q.passed = q.problem.empty();
    result.queries.push_back(std::move(q));
  }
  return result;
}

std::string WritePlanningReport(const std::string& out_dir, const PlanningSuite& suite,
                                const core::RobotModel& model, const PlanningResult& result) {
  fs::create_directories(out_dir);
  Json json;
  json["format"] = "sirupp-grade-planning-results-1";
  json["suite"] = suite.name;
  json["model"] = model.name;
  json["environment"] = fs::path(suite.environment_file).filename().string();
  json["submission"] = result.label;
  json["passed"] = result.passed();
  json["queries"] = static_cast<int>(result.queries.size());
  json["score_percent"] = result.score();
  Json list = Json::array();
  for (const PlanningQueryResult& q : result.queries) {
    Json entry;
    entry["query"] = q.query;
    entry["passed"] = q.passed;
    entry["problem"] = q.problem;
    entry["waypoints"] = static_cast<int>(q.path.size());
    entry["length_rad"] = q.length_rad;
    entry["duration_s"] = q.duration_s;
    entry["ran_on_rig"] = q.ran;
    entry["touching_ticks"] = q.touching_ticks;
    entry["end_error_deg"] = q.end_error_rad * 180 / kPi;
    entry["reference_solved"] = q.reference_solved;
    entry["reference_length_rad"] = q.reference_length_rad;
    entry["reference_duration_s"] = q.reference_duration_s;
    list.push_back(entry);
  }
  json["results"] = list;
  const std::string text = json.dump(2) + "\n";
  std::ofstream(fs::path(out_dir) / "results.json", std::ios::binary) << text;

  std::ostringstream md;
  md << "# " << suite.name << ": " << result.label << "\n\n"
     << (suite.description.empty() ? "" : suite.description + "\n\n") << "Environment "
     << suite.environment_file << ", model " << model.name << ". Paths checked every "
     << Num(suite.check_step_rad) << " rad with " << Num(suite.check_padding_m * 1000)
     << " mm of padding, then run on a rig (sirupp-sim with the environment, the PIC-SERVO PID). "
     << "Reference: OMPL " << suite.reference.planner << ", seed " << suite.reference.seed
     << ", with the student's padding " << Num(suite.student_padding_m * 1000) << " mm.\n\n"
     << "Passed " << result.passed() << " of " << result.queries.size() << " ("
     << Approx(result.score()) << " %).\n\n"
     << "| query | result | waypoints | length (rad) | OMPL's (rad) | run (s) | OMPL's (s) | "
        "planning (s) | OMPL's (s) | in the sim |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const PlanningQueryResult& q : result.queries) {
    md << "| " << q.query << " | " << (q.passed ? "passed" : "**failed**") << " | " << q.path.size()
       << " | " << Approx(q.length_rad) << " | "
       << (q.reference_solved ? Approx(q.reference_length_rad) : "not solved") << " | "
       << Approx(q.duration_s) << " | " << Approx(q.reference_duration_s) << " | "
       << Approx(q.student_s) << " | " << Approx(q.reference_s) << " | "
       << (q.ran ? std::to_string(q.ticks) + " ticks, " + std::to_string(q.touching_ticks) +
                       " touching, ends " + Approx(q.end_error_rad * 180 / kPi) + " deg off"
                 : "not run")
       << " |\n";
  }
  for (const PlanningQueryResult& q : result.queries) {
    if (!q.passed) md << "\n- **" << q.query << "**: " << q.problem << "\n";
  }
  std::ofstream(fs::path(out_dir) / "report.md", std::ios::binary) << md.str();
  return core::Fnv1aHex(text);
}

std::string PlanningSummaryLine(const PlanningSuite& suite, const PlanningResult& result,
                                const std::string& hash) {
  std::string line = "grade " + suite.name + ": " + result.label + " passed " +
                     std::to_string(result.passed()) + " of " +
                     std::to_string(result.queries.size()) + " queries (" + Approx(result.score()) +
                     " %)";
  for (const PlanningQueryResult& q : result.queries) {
    if (!q.passed) line += "; " + q.query + ": " + q.problem;
  }
  return line + "; results.json " + hash;
}

}  // namespace sirupp::grade
