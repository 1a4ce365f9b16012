// Planning libraries that break the rules of include/sirupp/student_planner.h, one per build:
// CMake compiles this file once per behaviour with -DBAD_PLANNER_<NAME> (tests/CMakeLists.txt,
// test_grade_planner_host). Each must cost the query with one clear line, never the grader.
//   straight   [start, goal]: a student's path straight through table.xml's table
//   crash      a write to address 16 (SIGSEGV)
//   spin       never returns
//   nan        a NaN in the middle waypoint
//   too_many   claims max_waypoints + 1 waypoints
//   no_count   returns OK without setting *num_waypoints
//   overrun    writes one waypoint past the buffer
//   refuses    returns 1 with its reason, after scene calls with bad arguments
//   throws     throws std::runtime_error out of sirupp_plan
//   wrong_abi  built against ABI version 99
//   no_plan    has the version but no sirupp_plan
#include <sirupp/student_planner.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>

#if defined(BAD_PLANNER_WRONG_ABI)
int sirupp_planner_abi_version(void) { return 99; }
#else
SIRUPP_PLANNER_ABI()
#endif

#if !defined(BAD_PLANNER_NO_PLAN)
int sirupp_plan(const double* start, const double* goal, int num_joints,
                const sirupp_planning_scene* scene, double* path, int max_waypoints,
                int* num_waypoints, char* error, int error_size) {
  const int n = num_joints;
  for (int j = 0; j < n; ++j) {
    path[j] = start[j];
    path[n + j] = 0.5 * (start[j] + goal[j]);
    path[2 * n + j] = goal[j];
  }
  *num_waypoints = 3;
#if defined(BAD_PLANNER_STRAIGHT)
  for (int j = 0; j < n; ++j) path[n + j] = goal[j];
  *num_waypoints = 2;
#elif defined(BAD_PLANNER_CRASH)
  volatile uintptr_t address = 16;
  *reinterpret_cast<volatile int*>(address) = 1;
#elif defined(BAD_PLANNER_SPIN)
  for (volatile unsigned long long i = 0;; i = i + 1) {
  }
#elif defined(BAD_PLANNER_NAN)
  path[n + 1] = std::nan("");
#elif defined(BAD_PLANNER_TOO_MANY)
  *num_waypoints = max_waypoints + 1;
#elif defined(BAD_PLANNER_NO_COUNT)
  *num_waypoints = -1;
#elif defined(BAD_PLANNER_OVERRUN)
  for (int i = 0; i <= max_waypoints; ++i) {
    for (int j = 0; j < n; ++j) path[i * n + j] = goal[j];
  }
  *num_waypoints = max_waypoints;
#elif defined(BAD_PLANNER_REFUSES)
  double bad[16] = {std::nan("")};
  const int free_nan = scene->is_free(scene->context, bad);
  const int edge_zero = scene->edge_free(scene->context, start, goal, 0.0);
  const int start_free = scene->is_free(scene->context, start);
  std::snprintf(error, static_cast<size_t>(error_size),
                "no path within 5 nodes (is_free(nan) = %d, edge_free(step 0) = %d, "
                "is_free(start) = %d)",
                free_nan, edge_zero, start_free);
  return SIRUPP_PLAN_FAILED;
#elif defined(BAD_PLANNER_THROWS)
  throw std::runtime_error("the tree is empty");
#endif
  (void)scene;
  (void)error;
  (void)error_size;
  (void)max_waypoints;
  return SIRUPP_PLAN_OK;
}
#endif
