#pragma once
// The processes of one grading task (sirupp-sim, sirupp-control or a student's controller
// process): started in a process group of their own with their output in a log file, watched
// without blocking, and ended by their group, so a controller's helpers (sirupp-controller-host,
// a JVM's threads) end with it. Safe to use from several threads: fork() is followed only by
// async-signal-safe calls until exec, and each child is reaped by its own pid.

#include <sys/types.h>

#include <string>
#include <vector>

namespace sirupp::grade {

class Child {
 public:
  Child() = default;
  ~Child();  // Stop()s a child still running
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  // Starts `argv` (argv[0] a path, or a name looked up on PATH) with stdin from /dev/null and
  // stdout and stderr appended to `log_file`. Throws std::runtime_error naming the program if it
  // cannot be started (a program that does not exist ends at once with exit code 127).
  void Start(const std::vector<std::string>& argv, const std::string& log_file);
  // True while the process runs; reaps it (once) when it has ended.
  bool Running();
  bool started() const { return pid_ > 0 || ended_; }
  bool ended() const { return ended_; }
  // How it ended: "exit code 3", "crashed with SIGSEGV (Segmentation fault)". Empty while running.
  std::string HowEnded() const;
  bool EndedCleanly() const;
  // SIGTERM to the group, up to `grace_s` for it to end, then SIGKILL to the group.
  void Stop(double grace_s = 1.0);
  // The last `lines` lines of the log file, joined by " | ".
  std::string LogTail(int lines = 3) const;
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  bool ended_ = false;
  int status_ = 0;
  std::string log_file_;
};

}  // namespace sirupp::grade
