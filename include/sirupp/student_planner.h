/* SIRUPP student planner interface: the only file a planning library needs (C or C++).
 *
 * A planning assignment (docs/grading.md, "Planning assignments") asks for a path in joint space
 * from a start to a goal around the objects of an environment. In C++ (or C) the student hands in
 * one source file, or a library built from it, that defines the two functions declared below:
 *
 *   #include <sirupp/student_planner.h>
 *   SIRUPP_PLANNER_ABI()   // once: exports sirupp_planner_abi_version
 *   int sirupp_plan(const double* start, const double* goal, int num_joints,
 *                   const sirupp_planning_scene* scene, double* path, int max_waypoints,
 *                   int* num_waypoints, char* error, int error_size) { ... }
 *
 *   sirupp grade my_planner.cpp --suite config/grading/planning.yaml
 *
 * The grader builds the file like a controller (g++ -std=c++17 -O2 -fPIC -shared -Wl,-z,defs, in
 * the sandbox) and runs it, once per query, in sirupp-planner-host inside the sandbox: no network,
 * only /usr, the library, the model and the environment to read, the query's own folder to write,
 * a private /tmp, the suite's limits.plan_s of wall time per call. A crash (any signal), a call
 * past the time limit, an exception, a nonzero return or a path that does not fit the buffer
 * fails that query with one line saying so; the grader itself is never harmed.
 *
 * Units: rad for revolute joints, m for prismatic ones (the PUMA 260 has six revolute joints).
 * A good solution: config/grading/planning_rrt.cpp (RRT-Connect with shortcutting).
 */

#ifndef SIRUPP_STUDENT_PLANNER_H_
#define SIRUPP_STUDENT_PLANNER_H_

/* Changes whenever a struct or function below changes layout or meaning; the host refuses a
 * library built against another version. */
#define SIRUPP_PLANNER_ABI_VERSION 1

#ifdef __cplusplus
extern "C" {
#endif

/* The arm in its world, served by the host from the project's collision model (the same one the
 * grader checks with, padded by the suite's student_padding_m). Valid during sirupp_plan only.
 * Every array has num_joints entries. Not thread-safe: call it from one thread. */
typedef struct sirupp_planning_scene {
  int abi_version;     /* SIRUPP_PLANNER_ABI_VERSION */
  int num_joints;      /* as sirupp_plan's num_joints */
  const double* lower; /* the soft limits (what sirupp-control accepts): sample within them */
  const double* upper;
  double padding_m;    /* around the arm's shapes against objects, in every check below */
  double time_limit_s; /* wall time this call may take (the suite's limits.plan_s) */
  void* context;       /* pass it to the callbacks */
  /* 1 when the arm at q touches nothing (static objects, free objects, itself), 0 when it
   * touches something, -1 for a q that is not num_joints finite numbers. */
  int (*is_free)(void* context, const double* q);
  /* 1 when the straight joint-space segment q0 -> q1 is free, checked at states no joint of
   * which moves more than step_rad from the previous one, q0 and q1 included; 0 when a state
   * touches; -1 for a non-finite q0 or q1 or a step_rad outside (0, 1]. */
  int (*edge_free)(void* context, const double* q0, const double* q1, double step_rad);
  /* What the arm at q touches, as one line ("link 3 (forearm) touches static object 'table_top'
   * by 4.2 mm at (...) m"), written into text (size bytes, always NUL-terminated); "" when free.
   * Returns as is_free does. For printing while debugging: slower than is_free. */
  int (*describe)(void* context, const double* q, char* text, int size);
  /* States checked so far by the calls above (what the report could count). */
  unsigned long long (*states_checked)(void* context);
} sirupp_planning_scene;

/* Return codes of sirupp_plan. */
#define SIRUPP_PLAN_OK 0
#define SIRUPP_PLAN_FAILED 1 /* any other value fails too: write why into `error` */

/* Returns SIRUPP_PLANNER_ABI_VERSION; define it with SIRUPP_PLANNER_ABI() below. */
int sirupp_planner_abi_version(void);

/* Plans from `start` to `goal` (num_joints values each, rad / m; both free and within the soft
 * limits). On success writes the path into `path` row by row (waypoint i, joint j at
 * path[i * num_joints + j]), at most max_waypoints rows (the buffer holds exactly that many: a
 * write past it crashes), sets *num_waypoints (1 to max_waypoints) and returns SIRUPP_PLAN_OK.
 * The first waypoint must be the start, the last the goal; the grader checks every straight
 * segment between waypoints at its own, finer resolution and without the padding, so a segment
 * the scene calls free at a coarse step may still touch. Otherwise returns nonzero with one line
 * saying why in `error` (error_size bytes, including the NUL). */
int sirupp_plan(const double* start, const double* goal, int num_joints,
                const sirupp_planning_scene* scene, double* path, int max_waypoints,
                int* num_waypoints, char* error, int error_size);

#ifdef __cplusplus
}
#endif

/* Defines sirupp_planner_abi_version; write it once in the library. */
#define SIRUPP_PLANNER_ABI() \
  int sirupp_planner_abi_version(void) { return SIRUPP_PLANNER_ABI_VERSION; }

#endif /* SIRUPP_STUDENT_PLANNER_H_ */
