#pragma once
// Runs one host's share of a lab layout: starts its processes in order (each after the previous is
// ready), restarts those whose layout says so, watches every process's HEARTBEAT (its own and the
// other hosts'), and stops them cleanly: SIGINT, a grace period, then SIGKILL.
//
// Each child runs in its own process group with its output in RUN_DIR/logs/NAME.log, and gets
// SIGTERM if the launcher itself dies (PR_SET_PDEATHSIG), so no process outlives its launcher.

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "launch/layout.hpp"

namespace sirupp::core {
class Bus;
}

namespace sirupp::launch {

struct SupervisorOptions {
  std::string host;     // the layout's host this supervisor runs
  std::string machine;  // this machine's name, as processes put it in their heartbeats
  std::string bin_dir;  // programs without a '/' are looked up here first, then on PATH
  std::string run_dir;  // ${RUN_DIR}; the processes' output goes to RUN_DIR/logs/NAME.log
  std::vector<std::pair<std::string, std::string>> variables;  // more ${NAME}s for commands
  std::ostream* events = nullptr;  // one line per start, ready, exit, restart, stop
  double restart_delay_s = 1.0;
  double silent_after_s = 3.0;  // a heartbeat older than this: the row says "silent"
};

// One row of the status table: a process of this host, or one heard on the bus.
struct ProcessRow {
  std::string name;  // layout name, or the heartbeat's process name for other hosts' processes
  std::string host;
  int pid = 0;
  std::string state;  // waiting, starting, running (or the heartbeat's state), silent, done, ...
  double uptime_s = 0;
  int restarts = 0;
  double in_hz = 0;      // messages received per second, all channels
  double out_hz = 0;     // messages sent per second, all channels
  int64_t rejected = 0;  // refused or undecodable messages, all channels
  int64_t late = 0;
  std::string detail;
  bool ours = false;  // started by this supervisor
};

class Supervisor {
 public:
  Supervisor(Layout layout, SupervisorOptions options);
  ~Supervisor();  // stops whatever still runs
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Starts this host's processes in layout order, each once the previous is ready. Returns false,
  // after stopping what it had started, when one cannot start or is not ready in time.
  // `keep_going` is polled while waiting, so Ctrl-C can interrupt a slow start.
  bool Start(const std::function<bool()>& keep_going);
  // Handles heartbeats and ended children for about `wait_ms`: restarts those whose layout says so.
  // Returns false once a critical process has ended for good.
  bool Service(int wait_ms);
  // Stops the running children one at a time, last started first: SIGINT, up to its
  // stop_timeout_s for it to end, else SIGKILL; then the next. Safe to call twice.
  void Stop();

  std::vector<ProcessRow> Table() const;
  // Failures so far: crashes, non-zero exits, missed readiness, a stop that needed SIGKILL.
  const std::vector<std::string>& failures() const { return failures_; }
  int ExitCode() const { return failures_.empty() ? 0 : 1; }
  const Layout& layout() const { return layout_; }
  const std::string& host() const { return options_.host; }
  // The command line a process runs with, variables replaced and LCM flags added.
  std::vector<std::string> CommandOf(const ProcessSpec& spec) const;
  // pid of a running child by layout name; 0 when not running.
  pid_t PidOf(const std::string& name) const;

 private:
  struct Child;
  struct Heard;
  using Clock = std::chrono::steady_clock;

  bool Spawn(Child& child);
  bool WaitReady(Child& child, const std::function<bool()>& keep_going);
  // The newest heartbeat of this child's process on this machine; nullptr if none was heard.
  const Heard* HeardFrom(const Child& child) const;
  bool HeardReady(const Child& child) const;
  std::string NotReadyWhy(const Child& child) const;
  void Reap();
  void Ended(Child& child, int status);
  void HandleHeartbeats(int wait_ms);
  void Event(const std::string& line) const;
  // Appends a timestamped line of the launcher's own to the process's log file.
  void NoteInLog(const Child& child, const std::string& line) const;
  std::string LogTail(const Child& child) const;

  Layout layout_;
  SupervisorOptions options_;
  std::unique_ptr<core::Bus> bus_;
  std::vector<std::unique_ptr<Child>> children_;
  std::map<std::string, std::unique_ptr<Heard>> heard_;  // by "process@host#pid"
  std::vector<std::string> failures_;
  bool stopping_ = false;
  bool critical_ended_ = false;
};

// The program to run for `program`: itself if it has a '/', else the first executable of that name
// in `bin_dir`, then on PATH; empty when there is none.
std::string ResolveProgram(const std::string& program, const std::string& bin_dir);

// Text of the status table: a header and one aligned line per row.
std::string FormatTable(const std::vector<ProcessRow>& rows);

}  // namespace sirupp::launch
