#pragma once
// The sandbox a student's code runs in (issue 34): the controller host of sirupp-control
// --controller and of `sirupp grade`, the compiler building a submitted .cpp, and later the class
// server's submissions. docs/sandbox.md says what holds and what stopped which hostile action.
//
// A sandbox is an argv prefix, so any spawn (posix_spawn, grade::Child) can use it unchanged:
//
//   bwrap --unshare-all --die-with-parent ...  Debian's bubblewrap: new user, network (only a
//                                               loopback of its own), pid, ipc, uts and cgroup
//                                               namespaces; a file system of /usr (read-only),
//                                               the paths the policy names, a private /tmp
//   sirupp-sandbox-exec [--user UID] --cpu S --memory MB --processes N --file-size MB
//                       --no-network --          inside: the rlimits, (as root) a uid of its own,
//                                               a seccomp filter refusing socket() for anything
//                                               but AF_UNIX, then exec
//   PROGRAM ARGS...
//
// Started by root, bubblewrap runs privileged without a user namespace (the kernel does not count
// root's processes, so RLIMIT_NPROC needs another uid) and the helper drops to a uid of its own.
// Descriptors the parent passes (the controller host's socket pair and memfd) stay open across
// both. The policy's paths appear at their own paths inside.

#include <cstdint>
#include <string>
#include <vector>

namespace sirupp::sandbox {

struct Limits {
  double cpu_s = 60;           // RLIMIT_CPU: SIGXCPU at this, SIGKILL a second later
  uint64_t memory_mb = 1024;   // RLIMIT_AS (address space); see Policy::sanitized_target
  int processes = 32;          // RLIMIT_NPROC, counted in the sandbox's own user namespace
  uint64_t file_size_mb = 64;  // RLIMIT_FSIZE: SIGXFSZ on a write past it
  uint64_t tmp_mb = 64;        // the private /tmp (a tmpfs) holds at most this
};

struct Policy {
  Limits limits;
  // Read-write inside (the code's own folder); may be empty. Made writable by the sandbox's user
  // when running as root.
  std::vector<std::string> read_write;
  // Visible read-only at their own paths: the library, the model, a submission's sources; one
  // that does not exist is not there inside either. /usr (with /lib, /lib64, /bin as its links)
  // and /etc/ld.so.cache are always there.
  std::vector<std::string> read_only;
  // The working directory inside ("" = /); it must be one of the paths or a folder above one.
  std::string chdir;
  // The program is built with AddressSanitizer, which reserves terabytes of address space: the
  // memory limit is then ASan's hard_rss_limit_mb instead of RLIMIT_AS. Default: whether this
  // build is (the controller host is built with the rest).
  bool sanitized_target = kSanitizedBuild;
  static const bool kSanitizedBuild;
};

// What the machine allows, probed once per process by starting `true` in the full sandbox.
// bubblewrap is `bwrap` on PATH, or the program the environment variable SIRUPP_BWRAP names.
struct Probe {
  bool usable = false;
  std::string problem;  // why not, when !usable: what is missing and what would fix it
  std::string bwrap;    // the bubblewrap found
  std::string helper;   // sirupp-sandbox-exec
  // Running as root: bubblewrap runs privileged (no user namespace) and the code runs as a uid of
  // its own (from 2000000), so that the process limit counts its processes only.
  bool as_root = false;
  bool seccomp = false;  // the socket filter is installed on this architecture
};
const Probe& ProbeMachine();

// The argv prefix for `argv` under `policy`: the full command to spawn. Throws
// std::runtime_error (the reason, from ProbeMachine or a path the sandbox's user cannot reach)
// when the sandbox cannot be had; the caller refuses to run the code then.
std::vector<std::string> Wrap(const Policy& policy, const std::vector<std::string>& argv);

// bwrap reports its command's death by signal N as exit code 128 + N; this turns such a
// waitpid() status back into the signal's, so that "crashed with SIGSEGV" still names it.
int UnwrapStatus(int status);

// The inside half (sirupp-sandbox-exec): applies the limits and, when `no_network`, the socket
// filter to this process. Returns "" or what failed.
std::string ApplyLimits(const Limits& limits, bool sanitized_target);
// RLIMIT_AS (unless sanitized_target), last before exec: the helper itself may be an ASan build.
std::string ApplyMemoryLimit(const Limits& limits, bool sanitized_target);
std::string ForbidNetworkSockets();
// Started as root, after the limits: become uid/gid `id` with no supplementary groups (which drops
// every capability), keeping the parent-death signal SIGKILL. Returns "" or what failed.
std::string DropTo(int id);

// One line naming the protections: "bubblewrap 0.8.0 namespaces (network, pid, ...), ...".
std::string Describe(const Probe& probe, const Limits& limits);

}  // namespace sirupp::sandbox
