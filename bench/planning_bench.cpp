// Motion planning figures (issue 48) for the PUMA 260 in table.xml and shelf.xml: collision checks
// per second, RRTConnect plan + simplify time (p50 / p95 / max) over random collision-free
// start/goal pairs and table-top pairs (the tool 2-8 cm over the table, start and goal >= 30 cm
// apart), the solved share within the time limit, path length against BIT* given 1 s, and the
// C-space slice of two joints at 1 degree. Goals: >= 300 000 states/s; p50 <= 10 ms, p95 <= 100 ms,
// all solved within 1 s; slice < 0.5 s.
//
//   build/bin/bench_planning [--pairs 200] [--bitstar 10] [--time 1] [--step 0.01]
//                            [--padding 0.01] [--states 200000] [--scene both|table|shelf]

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "control/plan.hpp"
#include "core/environment.hpp"
#include "core/model_loader.hpp"
#include "core/motion_limits.hpp"
#include "planning/planner.hpp"
#include "runtime/args.hpp"

namespace {

using namespace sirupp;
using planning::JointVector;
constexpr double kDeg = 3.14159265358979323846 / 180;

std::string LoadAverage() {
  std::ifstream file("/proc/loadavg");
  std::string a, b, c;
  file >> a >> b >> c;
  return a + " " + b + " " + c;
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(std::ceil(p * v.size())) - 1);
  return v[i];
}

JointVector RandomState(const core::RobotModel& model, std::mt19937& rng) {
  const core::MotionLimits limits = core::DefaultMotionLimits(model);
  JointVector q(model.num_joints());
  for (int j = 0; j < model.num_joints(); ++j) {
    q[j] = std::uniform_real_distribution<double>(core::SoftMin(model, limits, j),
                                                  core::SoftMax(model, limits, j))(rng);
  }
  return q;
}

struct Pair {
  JointVector start, goal;
};

// Random free states that RRTConnect connects to the ready pose within 3 s: a free state can lie
// in a pocket of the C-space no path leaves (e.g. the upper arm pointing down and back with the
// forearm folded under it, shut in by the floor and the joint limits); such pairs have no answer
// for any planner and are counted apart.
std::vector<Pair> RandomPairs(planning::CollisionModel& cm, int count, std::mt19937& rng,
                              int& pockets) {
  const JointVector ready = core::ToJointVector(cm.model().FindNamedPose("ready")->position);
  std::vector<Pair> pairs;
  pockets = 0;
  auto free_state = [&] {
    for (;;) {
      JointVector q = RandomState(cm.model(), rng);
      if (!cm.IsFree(q)) continue;
      planning::PlanRequest probe;
      probe.time_limit_s = 3;
      probe.simplify = false;
      if (planning::PlanPath(cm, q, ready, probe).solved) return q;
      ++pockets;
    }
  };
  while (static_cast<int>(pairs.size()) < count) pairs.push_back({free_state(), free_state()});
  return pairs;
}

// The tool 2-8 cm over table.xml's top (upper face z = 0.12), pointing down with a random yaw;
// start and goal at least 0.3 m apart in y.
std::vector<Pair> TableTopPairs(planning::CollisionModel& cm, int count, std::mt19937& rng) {
  const core::RobotModel& model = cm.model();
  JointVector home(model.num_joints());
  for (int j = 0; j < model.num_joints(); ++j) home[j] = model.joints[static_cast<size_t>(j)].home;
  std::uniform_real_distribution<double> x(0.27, 0.42), y(-0.25, 0.25), z(0.14, 0.20),
      yaw(-kDeg * 90, kDeg * 90);
  auto tool_state = [&](double y_value, JointVector& q) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = Eigen::Vector3d(x(rng), y_value, z(rng));
    pose.linear() = core::QuaternionFromRpy(0, 180 * kDeg, yaw(rng)).toRotationMatrix();
    try {
      q = planning::ToolGoal(cm, pose, "nearest", home);
      return true;
    } catch (const std::invalid_argument&) {
      return false;
    }
  };
  std::vector<Pair> pairs;
  int tries = 0;
  while (static_cast<int>(pairs.size()) < count && tries++ < 100000) {
    const double ya = y(rng);
    double yb = y(rng);
    if (std::abs(ya - yb) < 0.3) continue;
    Pair p;
    if (tool_state(ya, p.start) && tool_state(yb, p.goal)) pairs.push_back(p);
  }
  return pairs;
}

struct Figures {
  std::vector<double> total_ms, length;
  int solved = 0, count = 0, straight = 0;
  std::vector<std::string> unsolved;  // "pair i: start [...] goal [...] deg: message"
};

std::string Degrees(const JointVector& q) {
  std::string out;
  for (int j = 0; j < q.size(); ++j) {
    char text[32];
    std::snprintf(text, sizeof text, "%s%.17g", j > 0 ? " " : "", q[j] / kDeg);
    out += text;
  }
  return out;
}

Figures PlanAll(planning::CollisionModel& cm, const std::vector<Pair>& pairs,
                const planning::PlanRequest& base) {
  Figures f;
  for (size_t i = 0; i < pairs.size(); ++i) {
    planning::PlanRequest request = base;
    request.seed = static_cast<uint32_t>(i + 1);
    if (cm.EdgeFree(pairs[i].start, pairs[i].goal, request.edge_step_rad)) ++f.straight;
    const planning::PlanResult r = planning::PlanPath(cm, pairs[i].start, pairs[i].goal, request);
    ++f.count;
    f.total_ms.push_back((r.solve_s + r.simplify_s) * 1000);
    if (r.solved) {
      ++f.solved;
      f.length.push_back(r.length_rad);
    } else {
      f.unsolved.push_back("pair " + std::to_string(i + 1) + " (seed " +
                           std::to_string(request.seed) + "): --from " + Degrees(pairs[i].start) +
                           " --to " + Degrees(pairs[i].goal) + ": " + r.message);
    }
  }
  return f;
}

void Print(const char* scene, const char* what, const Figures& f) {
  std::printf(
      "  %-6s %-9s %3d/%3d solved (%d straight), plan+simplify ms p50 %.2f  p95 %.2f  "
      "max %.1f, length p50 %.2f rad   [load %s]\n",
      scene, what, f.solved, f.count, f.straight, Percentile(f.total_ms, 0.5),
      Percentile(f.total_ms, 0.95), Percentile(f.total_ms, 1.0), Percentile(f.length, 0.5),
      LoadAverage().c_str());
  for (const std::string& line : f.unsolved) std::printf("    unsolved %s\n", line.c_str());
}

// RRTConnect + simplify against BIT* (1 s, simplified too) on the first `count` pairs.
void AgainstBitStar(planning::CollisionModel& cm, const std::vector<Pair>& pairs, int count,
                    const planning::PlanRequest& base, const char* scene, const char* what) {
  std::vector<double> ratios;
  int bit_solved = 0;
  for (int i = 0; i < std::min<int>(count, static_cast<int>(pairs.size())); ++i) {
    planning::PlanRequest request = base;
    request.seed = static_cast<uint32_t>(i + 1);
    const planning::PlanResult rrt = planning::PlanPath(cm, pairs[i].start, pairs[i].goal, request);
    request.planner = "bitstar";
    request.time_limit_s = 1.0;
    const planning::PlanResult bit = planning::PlanPath(cm, pairs[i].start, pairs[i].goal, request);
    if (bit.solved) ++bit_solved;
    if (rrt.solved && bit.solved && bit.length_rad > 0) {
      ratios.push_back(rrt.length_rad / bit.length_rad);
    }
  }
  std::printf(
      "  %-6s %-9s RRTConnect length / BIT* (1 s) length over %zu pairs: p50 %.3f  "
      "p95 %.3f (BIT* solved %d)   [load %s]\n",
      scene, what, ratios.size(), Percentile(ratios, 0.5), Percentile(ratios, 0.95), bit_solved,
      LoadAverage().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> raw(argv + 1, argv + argc);
  const runtime::Args args(
      raw, "bench_planning",
      {runtime::Flag("pairs", "random pairs per scene").Takes("N").Integer(1, 100000),
       runtime::Flag("table-top", "table-top pairs").Takes("N").Integer(0, 100000),
       runtime::Flag("bitstar", "pairs compared with BIT*").Takes("N").Integer(0, 1000),
       runtime::Flag("time", "time limit per plan, s").Takes("S").Above(0, 60),
       runtime::Flag("step", "edge step, rad").Takes("RAD").Above(0, 0.2),
       runtime::Flag("padding", "padding, m").Takes("M").Range(0, 0.1),
       runtime::Flag("fallback", "the fallback planner, or none").Takes("NAME"),
       runtime::Flag("fallback-after", "states the first planner checks before the fallback")
           .Takes("N")
           .Integer(1, 1000000000),
       runtime::Flag("planner", "the first planner").Takes("NAME").OneOf(planning::PlannerNames()),
       runtime::Flag("scene", "the scenes to measure")
           .Takes("NAME")
           .OneOf({"both", "table", "shelf"}),
       runtime::Flag("states", "random states for the check rate")
           .Takes("N")
           .Integer(1, 100000000)});
  const int pair_count = static_cast<int>(args.Integer("pairs", 200));
  const int table_top_count = static_cast<int>(args.Integer("table-top", 100));
  const int bit_count = static_cast<int>(args.Integer("bitstar", 10));
  const int states = static_cast<int>(args.Integer("states", 200000));
  planning::PlanRequest base;
  base.time_limit_s = args.Number("time", 1.0);
  base.edge_step_rad = args.Number("step", 0.01);
  const double padding = args.Number("padding", 0.01);
  if (args.Has("planner")) base.planner = args.String("planner");
  if (args.Has("fallback")) {
    base.fallback_planner = args.String("fallback") == "none" ? "" : args.String("fallback");
  }
  base.fallback_after_states = args.Integer("fallback-after", base.fallback_after_states);

  const core::RobotModel model = core::LoadRobotModel("config/robots/puma260.yaml");
  std::printf(
      "bench_planning: PUMA 260, %s (range 1 rad), then %s after %lld states checked, edge step "
      "%.3g rad, padding %.0f mm, time limit %.3g s\n",
      base.planner.c_str(), base.fallback_planner.empty() ? "none" : base.fallback_planner.c_str(),
      static_cast<long long>(base.fallback_after_states), base.edge_step_rad, padding * 1000,
      base.time_limit_s);
  const std::string scenes = args.Has("scene") ? args.String("scene") : "both";
  for (const char* scene : {"table", "shelf"}) {
    if (scenes != "both" && scenes != scene) continue;
    const core::Environment env =
        core::LoadEnvironment(std::string("config/environments/") + scene + ".xml");
    planning::CollisionModel cm(model, env, {padding, true});
    std::mt19937 rng(48);
    std::vector<JointVector> qs;
    for (int i = 0; i < states; ++i) qs.push_back(RandomState(model, rng));
    int free = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (const JointVector& q : qs) free += cm.IsFree(q) ? 1 : 0;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "  %-6s states checked: %.0f /s (%d random states, %.1f %% free, %zu objects, %zu "
        "self pairs)   [load %s]\n",
        scene, states / s, states, 100.0 * free / states, env.objects.size(), cm.SelfPairs().size(),
        LoadAverage().c_str());
    int pockets = 0;
    const std::vector<Pair> random_pairs = RandomPairs(cm, pair_count, rng, pockets);
    std::printf(
        "  %-6s %d random free states not connected to the ready pose within 3 s (left "
        "out)\n",
        scene, pockets);
    Print(scene, "random", PlanAll(cm, random_pairs, base));
    AgainstBitStar(cm, random_pairs, bit_count, base, scene, "random");
    if (std::string(scene) == "table" && table_top_count > 0) {
      const std::vector<Pair> top = TableTopPairs(cm, table_top_count, rng);
      Print(scene, "table-top", PlanAll(cm, top, base));
      AgainstBitStar(cm, top, bit_count, base, scene, "table-top");
    }
    JointVector q = JointVector::Zero(6);
    q[4] = 45 * kDeg;
    const planning::CSpaceSlice slice = planning::ComputeCSpaceSlice(cm, q, 1, 2, 1 * kDeg);
    std::printf(
        "  %-6s C-space slice j2 x j3 at 1 deg (others 0, j5 45 deg): %zu cells, %.1f %% "
        "free, %.3f s   [load %s]\n",
        scene, slice.cells.size(), 100.0 * slice.free_count() / slice.cells.size(), slice.seconds,
        LoadAverage().c_str());
  }
  return 0;
}
