#include "planning/planner.hpp"

#include <ompl/base/MotionValidator.h>
#include <ompl/base/PlannerData.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/RealVectorStateProjections.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/base/terminationconditions/IterationTerminationCondition.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/kpiece/KPIECE1.h>
#include <ompl/geometric/planners/prm/PRM.h>
#include <ompl/geometric/planners/rrt/RRT.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/geometric/planners/sbl/SBL.h>
#include <ompl/util/Console.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "core/errors.hpp"
#include "core/motion_limits.hpp"

namespace sirupp::planning {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;
using core::FormatNumber;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDefaultRange = 1.0;  // rad

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

void QuietOmpl() {
  static std::once_flag once;
  std::call_once(once, [] { ompl::msg::setLogLevel(ompl::msg::LOG_ERROR); });
}

JointVector ToVector(const ob::State* state, int n) {
  const auto* values = state->as<ob::RealVectorStateSpace::StateType>()->values;
  JointVector q(n);
  for (int j = 0; j < n; ++j) q[j] = values[j];
  return q;
}

void FromVector(const JointVector& q, ob::State* state) {
  auto* values = state->as<ob::RealVectorStateSpace::StateType>()->values;
  for (int j = 0; j < q.size(); ++j) values[j] = q[j];
}

// Uniform samples from a generator seeded for this call (OMPL's own are seeded per process).
class SeededSampler : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, uint32_t seed) : ob::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

template <class Base>
class Seeded : public Base {
 public:
  Seeded(const ob::SpaceInformationPtr& si, uint32_t seed) : Base(si) {
    this->rng_.setLocalSeed(seed);
  }
};

class SeededSimplifier : public og::PathSimplifier {
 public:
  SeededSimplifier(const ob::SpaceInformationPtr& si, uint32_t seed) : og::PathSimplifier(si) {
    rng_.setLocalSeed(seed);
  }
};

// Every edge through CollisionModel at an absolute step: the same sweep as `plan check`.
class EdgeValidator : public ob::MotionValidator {
 public:
  EdgeValidator(const ob::SpaceInformationPtr& si, CollisionModel& model, double step,
                CheckFilter filter)
      : ob::MotionValidator(si), model_(model), step_(step), filter_(filter) {}

  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const int n = model_.num_joints();
    // s1 too: the simplifier starts shortcuts at states it interpolated on a segment, which the
    // segment's check at the step did not visit.
    const JointVector a = ToVector(s1, n);
    const bool ok =
        model_.IsFree(a, filter_) && model_.EdgeFree(a, ToVector(s2, n), step_, filter_);
    (ok ? valid_ : invalid_)++;
    return ok;
  }

  bool checkMotion(const ob::State* s1, const ob::State* s2,
                   std::pair<ob::State*, double>& last_valid) const override {
    const int n = model_.num_joints();
    const JointVector a = ToVector(s1, n), b = ToVector(s2, n);
    const EdgeCheck edge = model_.CheckEdge(a, b, step_, filter_);
    if (edge.free) {
      ++valid_;
      return true;
    }
    // The last free state before the first touching one.
    const double longest = (b - a).cwiseAbs().maxCoeff();
    const int steps = std::max(1, static_cast<int>(std::ceil(longest / step_)));
    const double t = std::max(0.0, edge.fraction - 1.0 / steps);
    if (last_valid.first != nullptr) FromVector(a + t * (b - a), last_valid.first);
    last_valid.second = t;
    ++invalid_;
    return false;
  }

 private:
  CollisionModel& model_;
  double step_;
  CheckFilter filter_;
};

std::string Degrees(const core::RobotModel& model, const JointVector& q) {
  std::ostringstream out;
  for (int j = 0; j < q.size(); ++j) {
    const bool revolute = model.joints[static_cast<size_t>(j)].type == core::JointType::kRevolute;
    char text[32];
    std::snprintf(text, sizeof text, "%.4g", revolute ? q[j] * 180 / kPi : q[j]);
    out << (j > 0 ? " " : "") << text;
  }
  return out.str();
}

ob::PlannerPtr MakePlanner(const std::string& name, const ob::SpaceInformationPtr& si,
                           uint32_t seed, double range) {
  if (name == "rrtconnect") {
    auto planner = std::make_shared<Seeded<og::RRTConnect>>(si, seed);
    planner->setRange(range);
    return planner;
  }
  if (name == "rrt") {
    auto planner = std::make_shared<Seeded<og::RRT>>(si, seed);
    planner->setRange(range);
    return planner;
  }
  if (name == "rrtstar") {
    auto planner = std::make_shared<Seeded<og::RRTstar>>(si, seed);
    planner->setRange(range);
    return planner;
  }
  if (name == "prm") return std::make_shared<Seeded<og::PRM>>(si, seed);
  if (name == "kpiece") {
    auto planner = std::make_shared<Seeded<og::KPIECE1>>(si, seed);
    planner->setRange(range);
    return planner;
  }
  if (name == "sbl") {
    auto planner = std::make_shared<Seeded<og::SBL>>(si, seed);
    planner->setRange(range);
    return planner;
  }
  if (name == "bitstar") return std::make_shared<og::BITstar>(si);
  return nullptr;
}

std::string JoinedNames() {
  std::string out;
  for (const std::string& name : PlannerNames()) out += (out.empty() ? "" : ", ") + name;
  return out;
}

void CheckRequest(const PlanRequest& r) {
  const auto& names = PlannerNames();
  if (std::find(names.begin(), names.end(), r.planner) == names.end()) {
    throw std::invalid_argument("planner '" + r.planner +
                                "' is not known; allowed: " + JoinedNames());
  }
  if (!r.fallback_planner.empty() &&
      std::find(names.begin(), names.end(), r.fallback_planner) == names.end()) {
    throw std::invalid_argument("fallback planner '" + r.fallback_planner +
                                "' is not known; allowed: none or " + JoinedNames());
  }
  if (r.fallback_after_states < 1 || r.fallback_after_states > 1000000000) {
    throw std::invalid_argument("fallback_after_states " + std::to_string(r.fallback_after_states) +
                                ": allowed 1 to 10^9 states");
  }
  if (!(r.edge_step_rad > 0 && r.edge_step_rad <= 0.2)) {
    throw std::invalid_argument("edge_step_rad " + FormatNumber(r.edge_step_rad) +
                                ": allowed (0, 0.2] rad");
  }
  if (!(r.time_limit_s > 0 && r.time_limit_s <= 600)) {
    throw std::invalid_argument("time_limit_s " + FormatNumber(r.time_limit_s) +
                                ": allowed (0, 600] s");
  }
  if (r.iteration_limit < 0 || r.iteration_limit > 1000000000) {
    throw std::invalid_argument("iteration_limit " + std::to_string(r.iteration_limit) +
                                ": allowed 0 (none) to 10^9");
  }
  if (!(r.range_rad >= 0 && r.range_rad <= 10)) {
    throw std::invalid_argument("range_rad " + FormatNumber(r.range_rad) +
                                ": allowed 0 (default) to 10 rad");
  }
}

}  // namespace

const std::vector<std::string>& PlannerNames() {
  static const std::vector<std::string> names{"rrtconnect", "rrt",    "prm", "rrtstar",
                                              "bitstar",    "kpiece", "sbl"};
  return names;
}

double PathLength(const std::vector<JointVector>& path) {
  double length = 0;
  for (size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

std::optional<std::string> EndpointProblem(CollisionModel& model, const JointVector& q,
                                           const std::string& what, const CheckFilter& avoid) {
  const core::RobotModel& robot = model.model();
  const int n = robot.num_joints();
  if (q.size() != n) {
    return what + ": " + std::to_string(q.size()) + " joint values; model " + robot.name + " has " +
           std::to_string(n) + " joints";
  }
  const core::MotionLimits limits = core::DefaultMotionLimits(robot);
  for (int j = 0; j < n; ++j) {
    const core::Joint& joint = robot.joints[static_cast<size_t>(j)];
    const bool revolute = joint.type == core::JointType::kRevolute;
    const double scale = revolute ? 180 / kPi : 1;
    const char* unit = revolute ? " deg" : " m";
    if (!std::isfinite(q[j])) {
      return what + ": joint j" + std::to_string(j + 1) + " (" + joint.name + ") is " +
             FormatNumber(q[j]) + "; allowed a finite value";
    }
    const double lo = core::SoftMin(robot, limits, j), hi = core::SoftMax(robot, limits, j);
    if (q[j] < lo - 1e-9 || q[j] > hi + 1e-9) {
      return what + ": joint j" + std::to_string(j + 1) + " (" + joint.name + ") " +
             FormatNumber(q[j] * scale) + unit + " is outside its soft limits [" +
             FormatNumber(lo * scale) + ", " + FormatNumber(hi * scale) + "]" + unit;
    }
  }
  if (const std::optional<Contact> contact = model.FirstContact(q, avoid)) {
    return what + " [" + Degrees(robot, q) + "] touches: " + model.Describe(*contact);
  }
  return std::nullopt;
}

JointVector ToolGoal(CollisionModel& model, const Eigen::Isometry3d& tool_pose,
                     const std::string& config, const JointVector& reference,
                     const CheckFilter& avoid) {
  const core::RobotModel& robot = model.model();
  const Eigen::Vector3d rpy = core::RollPitchYaw(tool_pose.linear());
  char pose_text[160];
  std::snprintf(pose_text, sizeof pose_text, "tool pose (%.4g %.4g %.4g m, %.4g %.4g %.4g deg)",
                tool_pose.translation().x(), tool_pose.translation().y(),
                tool_pose.translation().z(), rpy.x() * 180 / kPi, rpy.y() * 180 / kPi,
                rpy.z() * 180 / kPi);
  const bool nearest = config.empty() || config == "nearest";
  std::optional<core::IkConfiguration> wanted;
  if (!nearest) {
    wanted = core::IkConfiguration::Parse(config);
    if (!wanted) {
      throw std::invalid_argument("configuration '" + config +
                                  "' is not known; allowed: nearest or e.g. right-up-noflip "
                                  "(shoulder left/right, elbow up/down, wrist noflip/flip)");
    }
  }
  const core::IkResult ik = core::SolveIk(robot, tool_pose, reference, core::IkRequest{});
  if (!ik.ok()) throw std::invalid_argument(std::string(pose_text) + ": " + ik.reason);
  std::string first_problem;
  for (const core::IkSolution& solution : ik.solutions) {
    if (!solution.within_limits) continue;
    if (wanted && !(solution.config && *solution.config == *wanted)) continue;
    const std::optional<std::string> problem =
        EndpointProblem(model, solution.q, "the IK solution", avoid);
    if (!problem) return solution.q;
    if (first_problem.empty()) first_problem = *problem;
  }
  if (first_problem.empty()) {
    throw std::invalid_argument(std::string(pose_text) + ": no solution in configuration " +
                                config + " within the joint limits");
  }
  throw std::invalid_argument(std::string(pose_text) + ": no usable solution" +
                              (nearest ? "" : " in configuration " + config) + "; " +
                              first_problem);
}

PlanResult PlanPath(CollisionModel& model, const JointVector& start, const JointVector& goal,
                    const PlanRequest& request) {
  CheckRequest(request);
  if (auto problem = EndpointProblem(model, start, "start", request.avoid)) {
    throw std::invalid_argument(*problem);
  }
  if (auto problem = EndpointProblem(model, goal, "goal", request.avoid)) {
    throw std::invalid_argument(*problem);
  }
  QuietOmpl();
  const core::RobotModel& robot = model.model();
  const int n = robot.num_joints();
  const uint64_t checked_before = model.states_checked();
  PlanResult result;
  result.planner = request.planner;

  auto space = std::make_shared<ob::RealVectorStateSpace>(static_cast<unsigned int>(n));
  const core::MotionLimits limits = core::DefaultMotionLimits(robot);
  ob::RealVectorBounds bounds(static_cast<unsigned int>(n));
  for (int j = 0; j < n; ++j) {
    bounds.setLow(static_cast<unsigned int>(j), core::SoftMin(robot, limits, j));
    bounds.setHigh(static_cast<unsigned int>(j), core::SoftMax(robot, limits, j));
  }
  space->setBounds(bounds);
  uint32_t sampler_count = 0;
  const uint32_t seed = request.seed;
  space->setStateSamplerAllocator([seed, &sampler_count](const ob::StateSpace* s) {
    return std::make_shared<SeededSampler>(s, seed * 2654435761U + 97 * ++sampler_count);
  });
  std::vector<unsigned int> components;
  std::vector<double> cells;
  for (int j = 0; j < std::min(n, 3); ++j) {
    components.push_back(static_cast<unsigned int>(j));
    cells.push_back(0.2);
  }
  space->registerDefaultProjection(
      std::make_shared<ob::RealVectorOrthogonalProjectionEvaluator>(space, cells, components));

  auto si = std::make_shared<ob::SpaceInformation>(space);
  const CheckFilter avoid = request.avoid;
  si->setStateValidityChecker([&model, n, avoid](const ob::State* state) {
    return model.IsFree(ToVector(state, n), avoid);
  });
  si->setMotionValidator(std::make_shared<EdgeValidator>(si, model, request.edge_step_rad, avoid));
  si->setup();

  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  ob::ScopedState<> start_state(space), goal_state(space);
  FromVector(start, start_state.get());
  FromVector(goal, goal_state.get());
  pdef->setStartAndGoalStates(start_state, goal_state);

  const double range = request.range_rad > 0 ? request.range_rad : kDefaultRange;
  ob::PlannerPtr planner = MakePlanner(request.planner, si, seed + 1, range);
  planner->setProblemDefinition(pdef);
  planner->setup();

  ob::IterationTerminationCondition iterations(
      request.iteration_limit > 0 ? static_cast<unsigned int>(request.iteration_limit) : 0U);
  // The fallback takes over when the first planner has checked fallback_after_states states
  // without a path (the heavy tail of narrow passages): a count, not a clock, so where it takes
  // over does not depend on the machine or its load. Never with an iteration limit, nor when the
  // first planner is the fallback.
  const bool may_fall_back = !request.fallback_planner.empty() &&
                             request.fallback_planner != request.planner &&
                             request.iteration_limit == 0;
  const uint64_t switch_at = checked_before + static_cast<uint64_t>(request.fallback_after_states);
  ob::PlannerTerminationCondition ptc =
      request.iteration_limit > 0
          ? ob::plannerOrTerminationCondition(
                ob::timedPlannerTerminationCondition(request.time_limit_s), iterations)
      : may_fall_back ? ob::plannerOrTerminationCondition(
                            ob::timedPlannerTerminationCondition(request.time_limit_s),
                            ob::PlannerTerminationCondition([&model, switch_at] {
                              return model.states_checked() >= switch_at;
                            }))
                      : ob::timedPlannerTerminationCondition(request.time_limit_s);

  const auto solve_start = std::chrono::steady_clock::now();
  ob::PlannerStatus status = planner->solve(ptc);
  result.solved_by = request.planner;
  if (may_fall_back && !(status == ob::PlannerStatus::EXACT_SOLUTION && pdef->hasExactSolution())) {
    const double remaining = request.time_limit_s - Seconds(solve_start);
    if (remaining > 0) {
      pdef->clearSolutionPaths();
      ob::PlannerPtr fallback = MakePlanner(request.fallback_planner, si, seed + 3, range);
      if (auto* bit = dynamic_cast<og::BITstar*>(fallback.get())) {
        bit->setStopOnSolnImprovement(true);  // the first solution is enough here
      }
      fallback->setProblemDefinition(pdef);
      fallback->setup();
      status = fallback->solve(ob::timedPlannerTerminationCondition(remaining));
      result.solved_by = request.fallback_planner;
      result.fell_back = true;
      planner = fallback;
    }
  }
  result.solve_s = Seconds(solve_start);

  if (request.keep_tree) {
    ob::PlannerData data(si);
    planner->getPlannerData(data);
    for (unsigned int v = 0; v < data.numVertices(); ++v) {
      result.tree.vertices.push_back(ToVector(data.getVertex(v).getState(), n));
    }
    for (unsigned int v = 0; v < data.numVertices(); ++v) {
      std::vector<unsigned int> out;
      data.getEdges(v, out);
      for (unsigned int w : out) {
        result.tree.edges.emplace_back(static_cast<int>(v), static_cast<int>(w));
      }
    }
  }

  const bool exact = status == ob::PlannerStatus::EXACT_SOLUTION && pdef->hasExactSolution();
  if (!exact) {
    result.states_checked = model.states_checked() - checked_before;
    const bool by_iterations =
        request.iteration_limit > 0 &&
        iterations.getTimesCalled() >= static_cast<unsigned int>(request.iteration_limit);
    std::ostringstream why;
    why << "no collision-free path from [" << Degrees(robot, start) << "] to ["
        << Degrees(robot, goal) << "] (deg) in " << model.environment().name << ": "
        << request.planner << " stopped after ";
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "%.3g s", result.solve_s);
    why << seconds << " ("
        << (by_iterations ? std::to_string(request.iteration_limit) + " iterations, the limit"
                          : "time limit " + FormatNumber(request.time_limit_s) + " s")
        << (result.fell_back ? "; " + request.fallback_planner + " after " +
                                   std::to_string(request.fallback_after_states) +
                                   " states checked by " + request.planner
                             : "")
        << "), " << result.states_checked << " states checked at an edge step of "
        << FormatNumber(request.edge_step_rad) << " rad, padding "
        << FormatNumber(model.options().padding_m * 1000) << " mm, seed " << request.seed
        << "; start and goal are free. Try a longer time, another planner or seed, or less "
           "padding";
    result.message = why.str();
    return result;
  }

  auto* path = pdef->getSolutionPath()->as<og::PathGeometric>();
  for (size_t i = 0; i < path->getStateCount(); ++i) {
    result.path.push_back(ToVector(path->getState(static_cast<unsigned int>(i)), n));
  }
  result.raw_length_rad = PathLength(result.path);
  if (request.simplify && path->getStateCount() > 2) {
    const auto simplify_start = std::chrono::steady_clock::now();
    SeededSimplifier simplifier(si, seed + 2);
    // Shortcuts until a round no longer shortens the path (at most 4 rounds): no smoothing, so
    // every waypoint stays a stop of a straight segment.
    simplifier.reduceVertices(*path);
    simplifier.collapseCloseVertices(*path);
    for (int round = 0; round < 4; ++round) {
      const double before = path->length();
      const auto states = static_cast<unsigned int>(path->getStateCount());
      simplifier.shortcutPath(*path, 4 * states + 20, 2 * states + 10);
      simplifier.reduceVertices(*path);
      if (path->length() > before - 1e-6) break;
    }
    result.simplify_s = Seconds(simplify_start);
    std::vector<JointVector> simplified;
    for (size_t i = 0; i < path->getStateCount(); ++i) {
      simplified.push_back(ToVector(path->getState(static_cast<unsigned int>(i)), n));
    }
    // Every segment of what is returned is checked again, at the same step: a shortcut checked
    // piecewise samples other states than the whole segment does, so a contact narrower than the
    // step can show in one and not the other. When the check fails, the planner's own path (whose
    // segments were checked as they are) is kept.
    bool all_free = true;
    for (size_t i = 1; i < simplified.size() && all_free; ++i) {
      all_free = model.EdgeFree(simplified[i - 1], simplified[i], request.edge_step_rad, avoid);
    }
    if (all_free) result.path = simplified;
  }
  // The path starts and ends exactly where asked.
  result.path.front() = start;
  result.path.back() = goal;
  result.length_rad = PathLength(result.path);
  result.states_checked = model.states_checked() - checked_before;
  result.solved = true;
  const std::string after = result.fell_back ? " (after " + request.planner + " found none)" : "";
  char text[320];
  std::snprintf(text, sizeof text,
                "solved by %s%s in %.1f ms (+ %.1f ms simplifying), %zu waypoints, %.3f rad "
                "(raw %.3f rad), %llu states checked",
                result.solved_by.c_str(), after.c_str(), result.solve_s * 1000,
                result.simplify_s * 1000, result.path.size(), result.length_rad,
                result.raw_length_rad, static_cast<unsigned long long>(result.states_checked));
  result.message = text;
  return result;
}

}  // namespace sirupp::planning
