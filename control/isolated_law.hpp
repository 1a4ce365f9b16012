#pragma once
// A student's controller library run in a child process, so that its crash cannot take
// sirupp-control down (issue 22). IsolatedEffortLaw is the EffortLaw of ControlNode; it starts
// `sirupp-controller-host` (control/controller_host_main.cpp), which loads the library with
// PluginEffortLaw and runs its Reset and Update for the parent, one call at a time.
//
// The exchange: a shared memory block (memfd, mapped by both) holds the call (the measured state,
// the set-points) and the answer (the efforts, or what the library threw); a Unix seqpacket
// socket pair carries one byte each way per call, "your turn". The socket doubles as the host's
// death notice: when the host ends, by a signal or otherwise, the parent's wait returns at once
// with end-of-file and the parent reaps it and names how it ended. A host that does not answer
// within the per-tick limit is killed (SIGKILL). Every such failure is thrown from Reset or Update
// as a std::runtime_error, which ControlNode turns into its latched fault: the arm is braked and
// the cause named until `sirupp clear-fault`; the next Reset then starts a new host process
// (the library is loaded and constructed afresh). The host ends with the parent: it ignores
// SIGINT and SIGTERM (a terminal's Ctrl-C and the launcher reach the whole process group; the
// parent ends it by closing the socket) and has SIGKILL as its parent-death signal; in the sandbox
// (sandbox/sandbox.hpp) the sandbox is started in a process group of its own instead and dies
// with sirupp-control (bwrap --die-with-parent). It runs at the
// parent's scheduling priority (set again at each Reset, so `--rt-priority` reaches it too).
//
// The dynamics (G, bias, M) are computed in the host, from the model sent in the shared block as
// an encoded robot_model_t, so the efforts are bit-identical to an in-process PluginEffortLaw.

#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "control/effort_law.hpp"
#include "core/robot_model.hpp"
#include "sandbox/sandbox.hpp"

namespace sirupp::control {

struct IsolationOptions {
  // The host program; empty = HostProgramFor(library) in the directory of the running program.
  std::string host_program;
  // Wall time one Reset or Update may take. A host still busy then is killed and the call fails
  // ("did not answer ... within"): in lockstep the sim waits for sirupp-control, so this limit is
  // what turns a hanging controller into a fault. A host that at the limit is only waiting for a
  // CPU (a loaded machine) is given more time while it waits (WaitWhileStarved).
  double tick_limit_s = 0.5;
  // Wall time for loading the library and running its constructor.
  double load_limit_s = 10;
  // The host runs in the sandbox (sandbox/sandbox.hpp, docs/sandbox.md): no network, only /usr
  // and the library file (read-only) and a private /tmp to see, the limits below. Where the
  // machine cannot give the sandbox, the constructor refuses (ControllerLoadError with the reason)
  // unless this is false (sirupp-control --no-sandbox), which runs the library unconfined.
  bool sandbox = true;
  // A host serves a rig for hours, so its CPU limit is large: the per-tick limit is what stops a
  // busy loop; RLIMIT_CPU bounds what escapes it (processes the library started).
  sandbox::Limits sandbox_limits = {1800, 1024, 32, 64, 128};
  // Folders the library may write besides its private /tmp (its owner's folder); none by default.
  std::vector<std::string> sandbox_read_write;
  // More paths the host sees read-only besides /usr, the host program and the library (a host
  // that needs files of its own, e.g. a Python host's module folder; /usr/lib/python3* is in /usr).
  std::vector<std::string> sandbox_read_only;
};

class IsolatedEffortLaw : public EffortLaw {
 public:
  // Starts the host, which loads `library` with `args` for `model`. Throws ControllerLoadError
  // (a ConfigError: exit 2 with one line) naming the file and the problem the host reported:
  // not loadable, not a SIRUPP controller, another ABI version, arguments refused, or a crash
  // or hang while loading.
  IsolatedEffortLaw(const std::string& library, const std::string& args,
                    const core::RobotModel& model, IsolationOptions options = {});
  ~IsolatedEffortLaw() override;
  IsolatedEffortLaw(const IsolatedEffortLaw&) = delete;
  IsolatedEffortLaw& operator=(const IsolatedEffortLaw&) = delete;

  const std::string& name() const override { return name_; }
  // A new host process unless the present one is fresh (started and not called yet), then the
  // library's Reset. After a fault (and after a sim restart) the library starts afresh.
  void Reset(const ControlInput& input) override;
  void Update(const ControlInput& input, std::vector<double>& effort) override;

  // The present host's process id (in the sandbox: of its sandbox, whose end ends the host), or
  // -1 when none runs (it ended and was reaped).
  pid_t host_pid() const { return pid_; }
  // Host processes started so far (1 after construction).
  int hosts_started() const { return hosts_started_; }

 private:
  void StartHost();
  // Waits for the new host's "ready"; stops it and throws ControllerLoadError when it does not
  // load the library.
  void AwaitLoad(const void* shared);
  void StopHost();
  // One call to the host; throws std::runtime_error naming what went wrong.
  void Call(int32_t op, const ControlInput& input, const char* what);
  // Waits for the host's byte until `limit_s` passes. 1: a byte (in *byte); 0: time is up;
  // -1: end of file (the host ended).
  int WaitForHost(double limit_s, char* byte);
  // After the per-tick limit passed without an answer: a host that is runnable but given less
  // than half a CPU is waiting for a CPU on a loaded machine, not looping and not blocked, so the
  // wait goes on, for at most max(kStarvedPatienceS, 10 limits). A host asleep at two looks in a
  // row (a blocking call), or given half a CPU or more without answering, or computing for a
  // whole limit more (an endless loop) fails within a look or two. Returns as WaitForHost.
  int WaitWhileStarved(double limit_s, char* byte);
  static constexpr double kStarvedPatienceS = 10;  // at least this long past the limit, starved
  static constexpr double kStarvedLookS = 0.05;    // how often the host's state is read then
  static constexpr double kLastLookS = 0.01;       // a last look for an answer before failing
  // Reaps the ended (or killed) host; returns how it ended `where` (e.g. "in Update"):
  // "crashed with SIGSEGV (Segmentation fault) in Update".
  std::string ReapHost(bool kill_first, const std::string& where);

  std::string library_, args_, name_, host_program_;
  IsolationOptions options_;
  int num_joints_ = 0;
  std::vector<uint8_t> model_bytes_;  // encoded robot_model_t
  pid_t pid_ = -1;
  int socket_ = -1;
  void* shared_ = nullptr;
  size_t shared_size_ = 0;
  uint64_t seq_ = 0;
  std::string past_limit_;  // what WaitWhileStarved saw past the limit, for the fault's text
  bool fresh_ = false;      // the host has not been called yet
  int hosts_started_ = 0;
};

// The host program that runs `library`, by its name: sirupp-python-controller-host for a
// controller written in Python (*.py, python/), sirupp-controller-host for a shared library.
std::string HostProgramName(const std::string& library);

// The start of every host program's main: dies with its parent, ignores the Ctrl-C and SIGTERM
// sent to sirupp-control's group (the parent ends it), checks it got `program FILE ARGS` and the
// socket as descriptor 3, and closes every descriptor past 4 (sirupp-control's LCM sockets).
// False, after a usage line on stderr naming `program` and its `file_kind`, when it was not
// started by sirupp-control: main then exits 2.
bool PrepareHostProcess(int argc, const char* program, const char* file_kind);

// The host's side (sirupp-controller-host): serves calls on `socket_fd` with the shared block
// `shared_fd` until the socket closes. Returns the process exit code: 0, or 2 when the library
// cannot be used (reported to the parent in the shared block first).
int RunControllerHost(int socket_fd, int shared_fd, const std::string& library,
                      const std::string& args);

// The same with the law made by `make_law` (which throws ControllerLoadError, or any
// std::exception, when it cannot): how sirupp-python-controller-host runs a Python controller.
using EffortLawFactory = std::function<std::unique_ptr<EffortLaw>(
    const std::string& library, const std::string& args, const core::RobotModel& model)>;
int RunControllerHost(int socket_fd, int shared_fd, const std::string& library,
                      const std::string& args, const EffortLawFactory& make_law);

}  // namespace sirupp::control
