#pragma once
// Collision-free paths in joint space with OMPL (Debian's libompl-dev 1.5): the state space is the
// joint box of the model's limits (moved inward by core::DefaultMotionLimits' soft-limit margin,
// so sirupp-hardware would accept every goal), the validity checker is a CollisionModel, and every
// edge is checked at an absolute resolution in radians (CollisionModel::EdgeFree), not OMPL's
// fraction of the space. Reads the model and environment through the CollisionModel; writes
// nothing.
//
// Reproducible: every random number of a planning call comes from generators seeded from
// `seed` for that call (the state samplers, the planner's own and the simplifier's), so the same
// request gives the same path in any process and after any earlier call, as long as the planner
// stops on its own (its first exact solution: RRTConnect, RRT, KPIECE, SBL, and the SBL fallback,
// which takes over after a count of checked states) or on the iteration budget, not on the clock.
// Only exact solutions count: no path is returned that ends short of the goal or touches anything
// the filter counts.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/inverse_kinematics.hpp"
#include "planning/collision_model.hpp"

namespace sirupp::planning {

// The planners by name: "rrtconnect" (default), "rrt", "prm", "rrtstar", "bitstar", "kpiece",
// "sbl".
const std::vector<std::string>& PlannerNames();

struct PlanRequest {
  std::string planner = "rrtconnect";
  double edge_step_rad = 0.01;  // edge resolution, (0, 0.2] rad: no joint moves more between checks
  double time_limit_s = 1.0;    // (0, 600]
  int64_t iteration_limit = 0;  // planner iterations (termination checks), 0 = no limit
  uint32_t seed = 1;
  bool simplify = true;    // OMPL's PathSimplifier (shortcuts, vertex reduction), re-checked
  double range_rad = 0.0;  // the longest tree edge of tree planners; 0 = 1 rad
  bool keep_tree = false;  // fill PlanResult::tree with the planner's graph
  CheckFilter avoid;       // what the path must not touch (default: everything)
  // When `planner` has checked fallback_after_states states (edge states included) without a
  // path, `fallback_planner` gets the rest of the time. RRTConnect's times are heavy-tailed: a
  // state deep in a narrow passage (shelf.xml: the upper arm down and back at its limit, the
  // forearm folded) can take it seconds to leave, where SBL (a lazy bidirectional planner that
  // grows its trees where they are sparse) leaves in tens of ms. The switch is a count, not a
  // clock, so a fallback that stops at its first path (sbl, rrt, kpiece) keeps the plan
  // reproducible. Not used with an iteration_limit; "" = no fallback; 1 to 10^9 states.
  std::string fallback_planner = "sbl";
  int64_t fallback_after_states = 20000;
};

// The planner's graph: vertices in joint space, edges as index pairs into vertices.
struct PlannerTree {
  std::vector<JointVector> vertices;
  std::vector<std::pair<int, int>> edges;
};

struct PlanResult {
  bool solved = false;
  std::vector<JointVector> path;  // waypoints, start first, goal last (when solved)
  std::string
      message;  // one line: "solved by rrtconnect in 3.1 ms ..." or why not and what was tried
  std::string planner;    // as asked
  std::string solved_by;  // the planner that ran last: `planner`, or the fallback
  bool fell_back = false;
  double solve_s = 0;  // both planners' time
  double simplify_s = 0;
  uint64_t states_checked = 0;  // states the collision model checked for this call
  double raw_length_rad = 0;    // joint-space length of the planner's path (Euclidean, rad)
  double length_rad = 0;        // after simplification
  PlannerTree tree;             // when keep_tree
};

// Checks the request (planner name, step, budgets), that start and goal have one finite value per
// joint inside the soft limits, and that neither touches anything `request.avoid` counts; throws
// std::invalid_argument naming what ("start", "goal", "planner", "edge_step_rad", ...), the value
// and what is allowed (a touching start or goal names the link, the object and the depth). Then
// plans; no path within the budget is solved = false with a message, never a touching path.
PlanResult PlanPath(CollisionModel& model, const JointVector& start, const JointVector& goal,
                    const PlanRequest& request = {});

// A goal given as a tool pose: the IK solution in `config` ("nearest" or "": the collision-free
// solution nearest `reference`; else a configuration name such as "right-up-noflip",
// core::IkConfiguration). Throws std::invalid_argument naming the pose and why: out of reach,
// outside the limits, no such configuration, or every solution touches (naming the first contact).
JointVector ToolGoal(CollisionModel& model, const Eigen::Isometry3d& tool_pose,
                     const std::string& config, const JointVector& reference,
                     const CheckFilter& avoid = {});

// Why q cannot be a start or goal (`what` names it in the text), or nullopt: count, finiteness,
// soft limits, contacts.
std::optional<std::string> EndpointProblem(CollisionModel& model, const JointVector& q,
                                           const std::string& what, const CheckFilter& avoid = {});

// Joint-space length of a path (sum of Euclidean segment lengths, rad).
double PathLength(const std::vector<JointVector>& path);

}  // namespace sirupp::planning
