#pragma once
// One student's private rig: sirupp-sim (realtime), sirupp-control and sirupp-logger as child
// processes on a udpm port of their own (ttl=0), and the panel's hub and API for that bus hosted in
// the class server's process (panel/: the same page and API as sirupp-panel).
//
// The processes and their flags are the private rig of proc/rig.hpp, started as proc::Child: by
// one long-lived thread (ProcessLauncher), so the PR_SET_PDEATHSIG they get (SIGTERM when the
// server dies, even by SIGKILL) never fires early because the forking thread ended. A rig's
// children share one process group, stopped with SIGINT, then SIGKILL after a grace period, and
// the port is given back only once nothing of the group is left. Each child runs niced and, where
// the build allows it, with an address-space limit (RLIMIT_AS; not under AddressSanitizer).

#include <sys/types.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "proc/child.hpp"

namespace sirupp::core {
class Bus;
}
namespace sirupp::panel {
class PanelHub;
class PanelApi;
}  // namespace sirupp::panel

namespace sirupp::classroom {

// A rig process's niceness, memory limit and CPU (proc/child.hpp).
using ChildLimits = proc::Limits;
// Starts the rigs' processes from one thread that lives as long as the server (proc/child.hpp).
using ProcessLauncher = proc::Launcher;

struct RigSpec {
  std::string student;
  std::string bin_dir;  // where sirupp-sim, sirupp-control, sirupp-logger are
  std::string robot;    // model file
  std::string folder;   // the student's folder: config/ (their copy), results/, logs/
  int port = 0;         // udpm port, ttl=0
  ChildLimits limits;
  // A student's controller (a built library or a .py; class/submissions.hpp) in place of the
  // PIC-SERVO law: sirupp-control --controller FILE, its host in the sandbox. "" = built-in law.
  std::string controller;
  // sirupp-sim --pace-ticks: the sim sleeps once per this many ticks (class file rigs.pace_ticks).
  int pace_ticks = 1;
  double ready_timeout_s = 10;
  double stop_grace_s = 3;
};

// The panel objects of a running rig, shared with open event streams (which keep them alive until
// they notice the hub stopped).
struct RigPanel {
  std::unique_ptr<core::Bus> bus;
  std::unique_ptr<panel::PanelHub> hub;
  std::unique_ptr<panel::PanelApi> api;
  ~RigPanel();
};

class Rig {
 public:
  Rig(RigSpec spec, ProcessLauncher& launcher);
  ~Rig();  // stops it
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;

  // Starts the hub and the processes and waits until the arm's state and the controller's status
  // are heard. Throws std::runtime_error (after stopping what started) naming the process that
  // failed, with the end of its log.
  void Start();
  // SIGINT to the group, SIGKILL after the grace period; the hub stops. Safe to call twice.
  void Stop();
  // Reaps children that ended; "" while all run, else "sirupp-X exited with status N".
  std::string CheckProcesses();
  // CPU use of the rig's processes since the previous call, in percent of one core.
  double CpuPercent();

  std::shared_ptr<RigPanel> panel() const { return panel_; }
  std::vector<pid_t> pids() const;
  pid_t process_group() const { return pgid_; }
  const RigSpec& spec() const { return spec_; }
  std::string url() const;
  double start_seconds() const { return start_s_; }

 private:
  struct Child {
    std::string name;
    proc::Child process;
  };
  void Launch(const std::string& name, const proc::ProcessSpec& process);

  RigSpec spec_;
  ProcessLauncher& launcher_;
  std::shared_ptr<RigPanel> panel_;
  std::vector<Child> children_;
  pid_t pgid_ = 0;
  double start_s_ = 0;
  double cpu_ticks_ = 0;
  std::chrono::steady_clock::time_point cpu_at_{};
};

// The udpm URL of a rig's port (proc::RigUrl).
std::string RigUrl(int port);

}  // namespace sirupp::classroom
