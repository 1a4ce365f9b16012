#pragma once
// The host of a student's C++ planning library (include/sirupp/student_planner.h) for a planning
// assignment (grade/planning_assignment.hpp): sirupp-planner-host (grade/planner_host_main.cpp)
// runs this, one query per process, inside the sandbox the grader wraps it in:
//
//   sirupp-planner-host LIBRARY MODEL ENVIRONMENT PADDING_M TIME_S OUT START... GOAL...
//
// It builds the scene the library is given from planning/'s collision model (MODEL in
// ENVIRONMENT, the arm padded by PADDING_M), loads LIBRARY (dlopen; its ABI version checked),
// calls sirupp_plan once with START and GOAL (num_joints numbers each, rad / m) and writes OUT
// as python/sirupp/plan_host.py does: "# seconds S" (the call's own wall time), then one line of
// num_joints numbers (%.17g, so nan and inf stay readable) per waypoint; the grader reads it and
// checks the path itself. Whatever the library does, the host ends with one line on stderr
// saying what went wrong and exit 1:
//   - not loadable, no sirupp_plan or sirupp_planner_abi_version, another ABI version;
//   - a nonzero return (its error text), an exception, *num_waypoints outside 1..max_waypoints;
//   - loading and planning past TIME_S of wall time (an interval timer; the grader's own deadline
//     and the sandbox's CPU limit stop a library that blocks the timer's signal);
//   - a write past either end of the path buffer (guard pages: the SIGSEGV is named, then the
//     host dies by it as by any other crash, which the grader names).
// Bad arguments to the host: exit 2 with the usage. A scene callback called with bad arguments
// returns -1 (never throws into the library); the first such call is named in the host's error
// if the call then fails.

#include <string>
#include <vector>

namespace sirupp::grade {

// Rows of the path buffer sirupp_plan gets (the grader reads no more waypoints than this).
inline constexpr int kMaxPlanWaypoints = 10000;
// Bytes of the error text buffer, with the NUL.
inline constexpr int kPlanErrorSize = 1024;

// The host's work: `args` are its command-line arguments after the program name. Returns the
// exit code (0: OUT written, 1: the library failed, 2: bad arguments), having written one line
// on stderr unless 0.
int RunPlannerHost(const std::vector<std::string>& args);

}  // namespace sirupp::grade
