#include "tools/planning_commands.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "control/plan_collision.hpp"
#include "control/plan_trace.hpp"
#include "core/environment.hpp"
#include "core/errors.hpp"
#include "core/kinematics.hpp"
#include "planning/collision_model.hpp"
#include "planning/plan_text.hpp"
#include "planning/planner.hpp"
#include "planning/sweep.hpp"
#include "runtime/data_path.hpp"
#include "tools/rig_args.hpp"

namespace sirupp::tools {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDefaultMakeStep = 0.01;  // rad
constexpr double kDefaultPadding = 0.01;   // m, plan make

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// --FLAG Q1 .. QN (degrees for revolute joints, metres for prismatic) or --FLAG NAME (a named pose
// of the model, or home).
core::JointVector JointsOrPose(const runtime::Args& parsed, const std::string& flag,
                               const core::RobotModel& model) {
  const std::vector<std::string>& values = parsed.Values(flag, -1);
  const int n = model.num_joints();
  core::JointVector q(n);
  if (values.size() == 1) {
    const std::string& name = values[0];
    if (name == "home") {
      for (int j = 0; j < n; ++j) q[j] = model.joints[static_cast<size_t>(j)].home;
      return q;
    }
    if (const core::NamedPose* pose = model.FindNamedPose(name)) {
      return core::ToJointVector(pose->position);
    }
    std::vector<std::string> names{"home"};
    for (const core::NamedPose& pose : model.named_poses) names.push_back(pose.name);
    // A single number for a one-joint arm is a joint value, not a name.
    if (n != 1) {
      throw core::UsageError("--" + flag + ": '" + name + "' is not a pose of model " + model.name +
                             "; give " + std::to_string(n) +
                             " joint values (deg) or a pose: " + JoinNames(names));
    }
  }
  if (static_cast<int>(values.size()) != n) {
    throw core::UsageError("--" + flag + ": " + std::to_string(values.size()) + " values; model " +
                           model.name + " has " + std::to_string(n) + " joints (give Q1 .. Q" +
                           std::to_string(n) + " in degrees, or a pose name)");
  }
  for (int j = 0; j < n; ++j) {
    const double v = runtime::ParseNumberArg(values[static_cast<size_t>(j)],
                                             "--" + flag + " value " + std::to_string(j + 1));
    const bool revolute = model.joints[static_cast<size_t>(j)].type == core::JointType::kRevolute;
    q[j] = revolute ? v * kPi / 180 : v;
  }
  return q;
}

Eigen::Isometry3d ToolPoseArg(const runtime::Args& parsed, const std::string& flag) {
  const std::vector<double> v = parsed.Numbers(flag, 6);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  pose.linear() = core::QuaternionFromRpy(v[3] * kPi / 180, v[4] * kPi / 180, v[5] * kPi / 180)
                      .toRotationMatrix();
  return pose;
}

core::Environment EnvironmentArg(const runtime::Args& parsed) {
  return core::LoadEnvironment(runtime::ResolveDataPath(parsed.String("env")));
}

// A library's refusal (std::invalid_argument) as a usage error naming the flag.
template <class F>
auto Flagged(const std::string& flag, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const std::invalid_argument& e) {
    throw core::UsageError(flag + ": " + e.what());
  }
}

core::JointVector Endpoint(const runtime::Args& parsed, const std::string& which,
                           const core::RobotModel& model, planning::CollisionModel& collision,
                           const core::JointVector& reference, const planning::CheckFilter& avoid) {
  const std::string tool_flag = which + "-tool";
  if (parsed.Has(tool_flag)) {
    if (parsed.Has(which)) {
      throw core::UsageError("--" + which + " and --" + tool_flag + ": give one of them");
    }
    const std::string config = parsed.Has("config") ? parsed.String("config") : "nearest";
    const Eigen::Isometry3d pose = ToolPoseArg(parsed, tool_flag);
    return Flagged("--" + tool_flag,
                   [&] { return planning::ToolGoal(collision, pose, config, reference, avoid); });
  }
  if (!parsed.Has(which)) {
    throw core::UsageError("--" + which + ": missing; give Q1 .. Q" +
                           std::to_string(model.num_joints()) + " (deg), a pose name, or --" +
                           tool_flag + " X Y Z ROLL PITCH YAW");
  }
  return JointsOrPose(parsed, which, model);
}

}  // namespace

const char* const kPlanMakeAbout =
    "  make: a collision-free plan from --from to --to around the objects of --env (and the arm\n"
    "  itself), planned with OMPL (--planner: rrtconnect, rrt, prm, rrtstar, bitstar, kpiece,\n"
    "  sbl; rrtconnect hands over to sbl after 20000 states checked without a path), each edge\n"
    "  checked at --step rad, the arm padded by --padding m. Joints in degrees, or a\n"
    "  pose name (home, zero, ready, ...); --to-tool X Y Z ROLL PITCH YAW (m, deg) with --config\n"
    "  (nearest, or e.g. right-up-noflip) for a tool goal. The same request with the same --seed\n"
    "  gives the same plan in any process (when the planner stops on its own or on --iterations,\n"
    "  not on --time). Each segment is one synchronized trapezoid, so the controller's set-points\n"
    "  stay on the checked segment. Exit 0: written; 1: no path within the budget (nothing\n"
    "  written); 2: bad input (a start or goal that touches, outside the limits, ...).\n"
    "  --expand FILE: every `move ... avoid` line of FILE becomes a planned path from where the\n"
    "  plan stands to that line's goals (--from: the plan's start, default home).\n";

std::vector<runtime::Flag> SweepFlags() {
  return {
      runtime::Flag("env", "environment file: also sweep every move for collisions").Takes("FILE"),
      runtime::Flag("step", "sweep resolution, rad (default 0.01)").Takes("RAD").Range(1e-4, 0.2),
      runtime::Flag("padding", "padding around the arm, m (default 0)").Takes("M").Range(0, 0.1),
      runtime::Flag("from", "start joints in degrees, or a pose name (default home)")
          .Takes("", -1)};
}

std::vector<double> CheckStart(const runtime::Args& parsed, const core::RobotModel& model) {
  if (!parsed.Has("from")) return control::HomePositions(model);
  const core::JointVector q = JointsOrPose(parsed, "from", model);
  return std::vector<double>(q.data(), q.data() + q.size());
}

bool SweepPlan(const runtime::Args& parsed, const core::RobotModel& model,
               const control::Plan& plan, const std::vector<double>& start, std::ostream& out) {
  const core::Environment environment = EnvironmentArg(parsed);
  planning::CollisionOptions options;
  options.padding_m = parsed.Number("padding", 0);
  planning::CollisionModel collision(model, environment, options);
  const double step = parsed.Number("step", control::kPlanCheckStepRad);
  const control::PlanCollisionReport report =
      control::CheckPlanCollisions(model, plan, start, collision, step);
  for (const planning::SweepFinding& f : report.free_touches) {
    out << control::FindingPlace(plan, f)
        << ": note: " << control::FindingDetail(model, collision, f)
        << " (a free object: the arm may push it)\n";
  }
  if (report.error) {
    out << control::FindingError(model, plan, collision, *report.error) << "\n";
    return false;
  }
  out << plan.name << ": no collision with " << environment.name << " or the arm itself ("
      << report.states_checked << " set-points checked at " << core::FormatNumber(step)
      << " rad, padding " << core::FormatNumber(options.padding_m * 1000) << " mm, "
      << core::FormatNumber(std::round(report.duration_s * 1000) / 1000) << " s of motion)\n";
  return true;
}

namespace {

// The units statement in force after the first `line - 1` lines of `lines` (angle and length).
std::string UnitsBefore(const std::vector<std::string>& lines, int line) {
  std::string angle = "deg", length = "m";
  for (int i = 0; i < line - 1 && i < static_cast<int>(lines.size()); ++i) {
    std::istringstream words(
        lines[static_cast<size_t>(i)].substr(0, lines[static_cast<size_t>(i)].find('#')));
    std::string word;
    if (!(words >> word) || word != "units") continue;
    while (words >> word) (word == "deg" || word == "rad" ? angle : length) = word;
  }
  return "units " + angle + " " + length;
}

// `plan make --expand FILE`: every `move ... avoid` line of FILE replaced by a planned path from
// where the plan stands (the arm at rest) to that line's goals.
int ExpandPlan(const runtime::Args& parsed, const core::RobotModel& model,
               planning::CollisionModel& collision, const planning::PlanRequest& request,
               const planning::PlanTextOptions& text_options, std::ostream& out) {
  const std::string file = parsed.String("expand");
  const std::string text = control::ReadPlanText(file);
  const std::vector<double> start = CheckStart(parsed, model);
  const control::Plan plan = control::ParsePlanWithAvoid(text, file, model, start, true);
  std::vector<std::string> lines;
  {
    std::istringstream stream(text);
    std::string line;
    while (std::getline(stream, line)) lines.push_back(line);
  }
  std::map<int, std::string> replaced;
  int planned = 0;
  for (const control::PlanStep& step : plan.steps) {
    if (!step.avoid) continue;
    std::vector<double> goal = step.from;
    for (size_t j = 0; j < step.moves.size(); ++j) {
      if (step.moves[j].active) goal[j] = step.moves[j].goal;
    }
    const std::string where = file + ":" + std::to_string(step.line) + ": " + step.text + ": ";
    planning::PlanResult result;
    try {
      result = planning::PlanPath(collision, core::ToJointVector(step.from),
                                  core::ToJointVector(goal), request);
    } catch (const std::invalid_argument& e) {
      throw core::UsageError(where + e.what());
    }
    if (!result.solved) {
      out << where << result.message << "\n";
      return 1;
    }
    planning::PlanTextOptions options = text_options;
    options.move_to_start = false;
    options.comments = {"line " + std::to_string(step.line) + ", planned around " +
                        collision.environment().name + ": " + step.text};
    replaced[step.line] = "# " + lines[static_cast<size_t>(step.line - 1)] + "\n" +
                          planning::PathToPlanText(model, result.path, options) +
                          UnitsBefore(lines, step.line + 1);
    out << where << result.message << "\n";
    ++planned;
  }
  std::string expanded;
  for (size_t i = 0; i < lines.size(); ++i) {
    const auto it = replaced.find(static_cast<int>(i) + 1);
    expanded += (it != replaced.end() ? it->second : lines[i]) + "\n";
  }
  // What is written is a plan sirupp-control takes: parsed once more, without `avoid`.
  (void)control::ParsePlan(expanded, parsed.String("output"), model, start);
  const std::string output = parsed.String("output");
  std::ofstream stream(output, std::ios::binary | std::ios::trunc);
  stream << expanded;
  if (!stream.good()) throw core::UsageError("--output: cannot write '" + output + "'");
  out << "wrote " << output << ": " << planned << " avoid move" << (planned == 1 ? "" : "s")
      << " planned\n";
  return 0;
}

}  // namespace

int PlanMake(const std::vector<std::string>& args, std::ostream& out) {
  const runtime::Args parsed(
      args, "plan make",
      {runtime::ModelFlag(), runtime::Flag("env", "environment file").Takes("FILE"),
       runtime::Flag("from", "start: Q1 .. QN in degrees, or a pose name").Takes("", -1),
       runtime::Flag("to", "goal: Q1 .. QN in degrees, or a pose name").Takes("", -1),
       runtime::Flag("from-tool", "start as a tool pose: m and deg")
           .Takes("X Y Z ROLL PITCH YAW", 6),
       runtime::Flag("to-tool", "goal as a tool pose: m and deg").Takes("X Y Z ROLL PITCH YAW", 6),
       runtime::Flag("config",
                     "IK configuration of a tool pose: nearest (default) or e.g. "
                     "right-up-noflip")
           .Takes("NAME"),
       runtime::Flag("planner", "rrtconnect (default), rrt, prm, rrtstar, bitstar, kpiece, sbl")
           .Takes("NAME")
           .OneOf(planning::PlannerNames()),
       runtime::Flag("seed", "random seed (default 1)").Takes("N").Integer(0, 4294967295L),
       runtime::Flag("time", "planning time limit, s (default 1)").Takes("S").Above(0, 600),
       runtime::Flag("iterations", "planner iteration limit (default none)")
           .Takes("N")
           .Integer(1, 1000000000L),
       runtime::Flag("step", "edge resolution, rad (default 0.01)").Takes("RAD").Above(0, 0.2),
       runtime::Flag("padding", "padding around the arm, m (default 0.01)")
           .Takes("M")
           .Range(0, 0.1),
       runtime::Flag("speed", "fraction of the joints' default speeds (default 1)")
           .Takes("F")
           .Above(0, 1),
       runtime::Flag("no-simplify", "keep the planner's raw path").Switch(),
       runtime::Flag("allow-free", "free objects may be touched (pushed)").Switch(),
       runtime::Flag("expand", "a plan whose `move ... avoid` lines are to be planned")
           .Takes("FILE"),
       runtime::Flag("output", "the plan file to write").Short('o').Takes("FILE")},
      std::string(kPlanMakeAbout));
  const core::RobotModel model = ModelFromArgs(parsed);
  if (!parsed.Has("env")) {
    throw core::UsageError(
        "plan make: --env: missing; give an environment file (e.g. "
        "config/environments/table.xml, or empty.xml)");
  }
  if (!parsed.Has("output")) throw core::UsageError("plan make: --output (-o): missing");
  const core::Environment environment = EnvironmentArg(parsed);
  planning::CollisionOptions options;
  options.padding_m = parsed.Number("padding", kDefaultPadding);
  planning::CollisionModel collision(model, environment, options);
  planning::PlanRequest request;
  request.planner = parsed.Has("planner") ? parsed.String("planner") : "rrtconnect";
  request.seed = static_cast<uint32_t>(parsed.Integer("seed", 1));
  request.time_limit_s = parsed.Number("time", 1.0);
  request.iteration_limit = parsed.Integer("iterations", 0);
  request.edge_step_rad = parsed.Number("step", kDefaultMakeStep);
  request.simplify = !parsed.Switch("no-simplify");
  if (parsed.Switch("allow-free")) request.avoid = planning::CheckFilter::StaticAndSelf();

  planning::PlanTextOptions text_options;
  text_options.speed_fraction = parsed.Number("speed", 1.0);
  if (parsed.Has("expand")) {
    if (parsed.Has("to") || parsed.Has("to-tool")) {
      throw core::UsageError("--expand: the goals come from the plan's avoid lines; no --to");
    }
    return ExpandPlan(parsed, model, collision, request, text_options, out);
  }
  core::JointVector home(model.num_joints());
  for (int j = 0; j < model.num_joints(); ++j) home[j] = model.joints[static_cast<size_t>(j)].home;
  const core::JointVector start = Endpoint(parsed, "from", model, collision, home, request.avoid);
  const core::JointVector goal = Endpoint(parsed, "to", model, collision, start, request.avoid);
  if (auto problem = planning::EndpointProblem(collision, start, "start", request.avoid)) {
    throw core::UsageError("--from: " + *problem);
  }
  if (auto problem = planning::EndpointProblem(collision, goal, "goal", request.avoid)) {
    throw core::UsageError("--to: " + *problem);
  }
  const planning::PlanResult result =
      Flagged("plan make", [&] { return planning::PlanPath(collision, start, goal, request); });
  if (!result.solved) {
    out << "plan make: " << result.message << "\n";
    return 1;
  }
  text_options.comments = {
      "Planned in " + environment.name + " (" + environment.source_file + ") for " + model.name,
      "from [" + control::JointsText(model, start) + "] deg to [" +
          control::JointsText(model, goal) + "] deg",
      request.planner + ", seed " + std::to_string(request.seed) + ", edge step " +
          core::FormatNumber(request.edge_step_rad) + " rad, padding " +
          core::FormatNumber(options.padding_m * 1000) + " mm" +
          (request.simplify ? ", simplified" : "")};
  const std::string text = planning::PathToPlanText(model, result.path, text_options);
  const std::string file = parsed.String("output");
  {
    std::ofstream stream(file, std::ios::binary | std::ios::trunc);
    stream << text;
    if (!stream.good()) throw core::UsageError("--output: cannot write '" + file + "'");
  }
  double duration = 0;
  for (size_t i = 1; i < result.path.size(); ++i) {
    duration += planning::SegmentDuration(model, result.path[i - 1], result.path[i], text_options);
  }
  char line[128];
  std::snprintf(line, sizeof line, "%zu segments, about %.2f s of motion", result.path.size() - 1,
                duration);
  out << result.message << "\nwrote " << file << ": " << line << "\n";
  return 0;
}

}  // namespace sirupp::tools
