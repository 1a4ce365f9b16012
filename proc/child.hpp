#pragma once
// One way to start and supervise a child process: fork and exec in a process group, a signal when
// the parent dies (PR_SET_PDEATHSIG), niceness, an address-space limit and a CPU, stdin from
// /dev/null and the output appended to a log file, reaping without blocking, and a stop that asks
// the group first (SIGTERM or SIGINT) and kills it (SIGKILL) after a grace period, returning only
// when nothing of the group is left.
//
// A ProcessSpec is plain data (argv, environment, log path, limits), so the same description can
// be run here or written as a command line (CommandLine) for a job script.
//
// Between fork and exec the child makes only async-signal-safe calls: everything it needs (argv,
// environment, the program's path, the log's descriptor) is made before the fork. Safe to use from
// several threads; each child is reaped by its own pid.
//
// PR_SET_PDEATHSIG fires when the *thread* that forked ends, not the process: a program that
// starts children from short-lived threads (a web server's request threads) starts them through a
// Launcher, whose one thread lives as long as the Launcher.

#include <signal.h>
#include <sys/types.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace sirupp::proc {

struct Limits {
  int nice = 0;       // niceness of the child (setpriority); 0 = the parent's
  int memory_mb = 0;  // address-space limit (RLIMIT_AS) in MiB; 0 = none. Not applied under
                      // AddressSanitizer, which reserves terabytes of address space.
  int cpu = -1;       // the one CPU it (and what it starts) runs on; -1 = any the parent may use
};

struct ProcessSpec {
  std::vector<std::string> argv;  // argv[0]: a path, or a name looked up on PATH
  std::vector<std::string> env;   // "NAME=VALUE", set over the parent's environment
  std::string log_path;           // stdout and stderr appended here; "" = the parent's
  Limits limits;
  int death_signal = SIGKILL;  // sent to the child when its parent dies; 0 = none
  // When the child ends, what is left of the process group it leads is killed (a controller's
  // helper processes end with it). Off for a group shared by several children that stop on their
  // own (a rig: the logger must finish its files after the sim ended).
  bool group_ends_with_it = false;
  // Written to the log when exec fails; "" = "exec failed: PROGRAM: no such program or not
  // executable".
  std::string exec_failed_line;
};

// The spec as one line of sh: NAME=VALUE words first, then argv, each quoted when it needs to be,
// and " >> LOG 2>&1" when it has a log.
std::string CommandLine(const ProcessSpec& spec);
// The same line with `exec` after the NAME=VALUE words, as a job script's last line: the program
// replaces the script's shell, so a signal to the job (scancel) reaches the program itself.
std::string ExecLine(const ProcessSpec& spec);

// Forks from one thread that lives as long as the Launcher (see above).
class Launcher {
 public:
  Launcher();
  ~Launcher();
  Launcher(const Launcher&) = delete;
  Launcher& operator=(const Launcher&) = delete;
  // Runs `fork_exec` on the launcher's thread and returns what it returns (rethrows its exception).
  pid_t Run(const std::function<pid_t()>& fork_exec);

 private:
  void Loop();
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> tasks_;
  bool stop_ = false;
  std::thread thread_;
};

class Child {
 public:
  Child() = default;
  ~Child();  // Stop(0.2)s a child still running
  Child(Child&& other) noexcept;
  Child& operator=(Child&& other) noexcept;
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  // Starts `spec` in process group `group` (0: a new group the child leads), through `launcher`
  // when one is given. Throws std::runtime_error naming the program when the log cannot be opened
  // or fork fails; a program that cannot be run ends at once with exit code 127 (the reason in
  // its log).
  void Start(const ProcessSpec& spec, pid_t group = 0, Launcher* launcher = nullptr);

  // True while the process runs; reaps it (once) when it has ended.
  bool Running();
  bool started() const { return pid_ > 0; }
  bool ended() const { return ended_; }
  int status() const { return status_; }  // waitpid's status once ended
  // How it ended: "exit code 3", "crashed with SIGSEGV (Segmentation fault)". "" while running.
  std::string HowEnded() const;
  bool EndedCleanly() const;
  pid_t pid() const { return pid_; }
  pid_t group() const { return group_; }
  const std::string& log_path() const { return log_path_; }

  // `first` (SIGTERM; 0 = none) to the group, up to `grace_s` for the child to end, then SIGKILL to
  // the group; returns once the child is reaped and nothing of its group is left (or after
  // kGroupGoneS more). True when the child ended within the grace period.
  bool Stop(double grace_s = 1.0, int first = SIGTERM);
  // The last `lines` non-empty lines of the log, joined by " | ", without a log prefix's leading
  // timestamp (runtime/log_prefix.hpp), so reasons read the same from run to run.
  std::string LogTail(int lines = 3) const;

  static constexpr double kGroupGoneS = 2.0;

 private:
  pid_t pid_ = -1;
  pid_t group_ = -1;
  bool ended_ = false;
  bool group_ends_with_it_ = false;
  int status_ = 0;
  std::string log_path_;
};

// True when no process of group `group` is left (zombies do not count: their parent reaps them).
bool GroupGone(pid_t group);
// SIGKILL to the group until nothing of it is left, at most `timeout_s`. True when gone.
bool KillGroup(pid_t group, double timeout_s = Child::kGroupGoneS);

}  // namespace sirupp::proc
