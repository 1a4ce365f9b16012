// sirupp-planner-host: runs one student planning library (include/sirupp/student_planner.h) on
// one query for `sirupp grade`, in the sandbox (grade/planner_host.hpp). Started by the grader,
// never by hand:
//
//   sirupp-planner-host LIBRARY MODEL ENVIRONMENT PADDING_M TIME_S OUT START... GOAL...

#include <sys/prctl.h>

#include <csignal>
#include <string>
#include <vector>

#include "grade/planner_host.hpp"

// In sanitizer builds: a crash in the library must end the host by its signal, which the grader
// names, not by the sanitizer's report; the library's leaks are not the host's failure.
extern "C" const char* __asan_default_options();
extern "C" const char* __asan_default_options() {
  return "handle_segv=0:handle_sigbus=0:handle_sigfpe=0:handle_abort=0:handle_sigill=0:"
         "detect_leaks=0";
}

int main(int argc, char** argv) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  return sirupp::grade::RunPlannerHost(std::vector<std::string>(argv + 1, argv + argc));
}
