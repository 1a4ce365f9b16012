#pragma once
// The processes of one grading task (sirupp-sim, sirupp-control or a student's controller
// process): a proc::Child (proc/child.hpp) in a process group of its own with its output in a log
// file, killed when the grader dies, and its group ended with it, so a controller's helpers
// (sirupp-controller-host, a JVM's threads) end with it. Also the Python module's rig processes.

#include <string>
#include <vector>

#include "proc/child.hpp"

namespace sirupp::grade {

class Child : public proc::Child {
 public:
  // Starts `argv` (argv[0] a path, or a name looked up on PATH) with stdin from /dev/null and
  // stdout and stderr appended to `log_file`. Throws std::runtime_error naming the program if it
  // cannot be started (a program that does not exist ends at once with exit code 127).
  void Start(const std::vector<std::string>& argv, const std::string& log_file);
  // SIGTERM to the group, up to `grace_s` for it to end, then SIGKILL to the group.
  void Stop(double grace_s = 1.0) { proc::Child::Stop(grace_s); }
};

}  // namespace sirupp::grade
