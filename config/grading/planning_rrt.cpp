// A good solution of the planning assignment (config/grading/planning.yaml) in C++: RRT-Connect
// (Kuffner and LaValle, 2000) in joint space with shortcutting, over the scene's checks
// (include/sirupp/student_planner.h). The same algorithm as config/grading/planning_rrt.py.
//
//   sirupp grade config/grading/planning_rrt.cpp --suite config/grading/planning.yaml
//
// The scene is padded (1 cm in that suite), so a path free here keeps that margin when the grader
// checks it unpadded at its finer resolution. Plain C++17 and the header, nothing else.

#include <sirupp/student_planner.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

SIRUPP_PLANNER_ABI()

namespace {

constexpr double kStep = 0.3;    // rad: the longest tree edge
constexpr double kCheck = 0.01;  // rad: the edge resolution of every check
constexpr int kMaxNodes = 20000;

using Joints = std::vector<double>;

class Tree {
 public:
  explicit Tree(const Joints& root) : nodes_{root}, parent_{-1} {}

  int Nearest(const Joints& q) const {
    int best = 0;
    double best_distance = INFINITY;
    for (size_t k = 0; k < nodes_.size(); ++k) {
      double distance = 0;
      for (size_t j = 0; j < q.size(); ++j) {
        const double d = nodes_[k][j] - q[j];
        distance += d * d;
      }
      if (distance < best_distance) {
        best_distance = distance;
        best = static_cast<int>(k);
      }
    }
    return best;
  }
  int Add(const Joints& q, int parent) {
    nodes_.push_back(q);
    parent_.push_back(parent);
    return static_cast<int>(nodes_.size()) - 1;
  }
  const Joints& Node(int k) const { return nodes_[static_cast<size_t>(k)]; }
  // The root .. node k.
  std::vector<Joints> Branch(int k) const {
    std::vector<Joints> out;
    for (; k >= 0; k = parent_[static_cast<size_t>(k)]) out.push_back(Node(k));
    std::reverse(out.begin(), out.end());
    return out;
  }

 private:
  std::vector<Joints> nodes_;
  std::vector<int> parent_;
};

class Planner {
 public:
  explicit Planner(const sirupp_planning_scene& scene) : scene_(scene) {}

  bool EdgeFree(const Joints& a, const Joints& b) const {
    return scene_.edge_free(scene_.context, a.data(), b.data(), kCheck) == 1;
  }

  // One step from the node nearest `target` towards it: the new node's index, or -1.
  int Extend(Tree& tree, const Joints& target) const {
    const int near = tree.Nearest(target);
    const Joints& from = tree.Node(near);
    double distance = 0;
    for (size_t j = 0; j < target.size(); ++j) distance += std::pow(target[j] - from[j], 2);
    distance = std::sqrt(distance);
    Joints next = target;
    if (distance > kStep) {
      for (size_t j = 0; j < target.size(); ++j) {
        next[j] = from[j] + (target[j] - from[j]) * (kStep / distance);
      }
    }
    if (!EdgeFree(from, next)) return -1;
    return tree.Add(next, near);
  }

  // Steps towards `target` until it is reached (the node's index) or blocked (-1).
  int Connect(Tree& tree, const Joints& target) const {
    for (;;) {
      const int k = Extend(tree, target);
      if (k < 0) return -1;
      if (tree.Node(k) == target) return k;
    }
  }

  std::vector<Joints> Shortcut(const std::vector<Joints>& path) const {
    std::vector<Joints> out{path.front()};
    size_t i = 0;
    while (i + 1 < path.size()) {
      size_t j = path.size() - 1;
      while (j > i + 1 && !EdgeFree(path[i], path[j])) --j;
      out.push_back(path[j]);
      i = j;
    }
    return out;
  }

  // The path from start to goal, or empty when none was found within kMaxNodes samples.
  std::vector<Joints> Plan(const Joints& start, const Joints& goal) const {
    if (EdgeFree(start, goal)) return {start, goal};
    std::mt19937 random(1);
    std::vector<std::uniform_real_distribution<double>> sample;
    for (int j = 0; j < scene_.num_joints; ++j) {
      sample.emplace_back(scene_.lower[j], scene_.upper[j]);
    }
    Tree trees[2] = {Tree(start), Tree(goal)};
    for (int i = 0; i < kMaxNodes; ++i) {
      Tree& a = trees[i % 2];  // grows from the start on even i, from the goal on odd i
      Tree& b = trees[1 - i % 2];
      Joints q(start.size());
      for (size_t j = 0; j < q.size(); ++j) q[j] = sample[j](random);
      const int k = Extend(a, q);
      if (k < 0) continue;
      const int m = Connect(b, a.Node(k));
      if (m < 0) continue;
      std::vector<Joints> path = a.Branch(k);
      std::vector<Joints> rest = b.Branch(m);
      path.insert(path.end(), rest.rbegin() + 1, rest.rend());
      if (i % 2) std::reverse(path.begin(), path.end());  // a grew from the goal
      return Shortcut(path);
    }
    return {};
  }

 private:
  const sirupp_planning_scene& scene_;
};

}  // namespace

int sirupp_plan(const double* start, const double* goal, int num_joints,
                const sirupp_planning_scene* scene, double* path, int max_waypoints,
                int* num_waypoints, char* error, int error_size) {
  const Joints from(start, start + num_joints), to(goal, goal + num_joints);
  const std::vector<Joints> found = Planner(*scene).Plan(from, to);
  if (found.empty()) {
    std::snprintf(error, static_cast<size_t>(error_size), "no path within %d nodes", kMaxNodes);
    return SIRUPP_PLAN_FAILED;
  }
  if (static_cast<int>(found.size()) > max_waypoints) {
    std::snprintf(error, static_cast<size_t>(error_size), "%zu waypoints; the buffer holds %d",
                  found.size(), max_waypoints);
    return SIRUPP_PLAN_FAILED;
  }
  for (size_t i = 0; i < found.size(); ++i) {
    std::copy(found[i].begin(), found[i].end(), path + i * static_cast<size_t>(num_joints));
  }
  *num_waypoints = static_cast<int>(found.size());
  return SIRUPP_PLAN_OK;
}
