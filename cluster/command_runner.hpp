#pragma once
// Runs an engine's command line (sbatch, squeue, scancel) as a child process with a time limit and
// says what became of it. The engines take a CommandRunner, so their tests give them a fake one
// that answers from a table (tests/test_cluster.cpp) and the same code runs against a real
// cluster with SystemRunner.

#include <string>
#include <vector>

namespace sirupp::cluster {

struct CommandResult {
  bool started = false;    // false: the program could not be run (not installed, fork failed)
  bool timed_out = false;  // killed after the time limit
  int exit_code = -1;      // when it ended by itself; -1 after a signal or a time-out
  std::string out;         // standard output
  std::string err;         // standard error
  bool Succeeded() const { return started && !timed_out && exit_code == 0; }
  // One line for a person: "sbatch: timed out after 10 s", "squeue: exit 1: <stderr's first line>".
  std::string Describe(const std::string& program) const;
};

class CommandRunner {
 public:
  virtual ~CommandRunner() = default;
  // argv[0] is looked up in PATH. `input` goes to its standard input (then closed).
  virtual CommandResult Run(const std::vector<std::string>& argv, const std::string& input,
                            double timeout_s) = 0;
};

// fork + exec, standard output and error read through pipes, SIGKILL to the child's process
// group at the time limit. Safe to call from several threads at once.
class SystemRunner : public CommandRunner {
 public:
  CommandResult Run(const std::vector<std::string>& argv, const std::string& input,
                    double timeout_s) override;
};

}  // namespace sirupp::cluster
