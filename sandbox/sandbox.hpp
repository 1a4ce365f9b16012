#pragma once
// The sandbox a student's code runs in (issue 34): the controller host of sirupp-control
// --controller, of `sirupp grade` and of the class server's submissions, and the compiler
// building a submitted .cpp. docs/sandbox.md says what holds and what stopped which hostile
// action.
//
// A sandbox is an argv prefix, so any spawn (posix_spawn, grade::Child) can use it unchanged:
//
//   sirupp-sandbox-exec --supervise --         outside: runs bubblewrap as its child, a
//                                               subreaper that kills what a bubblewrap killed
//                                               during its set-up leaves behind, and ends with it
//   (as root, instead) sirupp-sandbox-exec --hold-uid --uid-at K [--give PATH]... --
//                                               the same, and first takes a uid no living sandbox
//                                               on the machine has, gives it the read-write
//                                               paths, puts it in word K below, and hands it to
//                                               bubblewrap, which holds it (HoldFreeUid)
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
// RLIMIT_NPROC then counts that uid's processes machine-wide, so no two living sandboxes may share
// it, whoever started them: the uid is held by a lock that bubblewrap's init (the sandbox's pid 1,
// whose end ends every process in it) keeps open as its --sync-fd, and the code never has.
// Descriptors the parent passes (the controller host's socket pair and memfd) stay open across
// all of them. The policy's paths appear at their own paths inside.

#include <cstdint>
#include <string>
#include <vector>

namespace sirupp::sandbox {

struct Limits {
  double cpu_s = 60;           // RLIMIT_CPU: SIGXCPU at this, SIGKILL a second later
  uint64_t memory_mb = 1024;   // RLIMIT_AS (address space); see Policy::sanitized_target
  int processes = 32;          // RLIMIT_NPROC, counted in the sandbox's own user namespace
                               // (as root: for the sandbox's own uid)
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
  // its own (from 2000000, held while the sandbox lives), so that the process limit counts its
  // processes only.
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
// Started as root, the outer step (sirupp-sandbox-exec --hold-uid), before bubblewrap: a uid from
// 2000000 up that no living sandbox on this machine holds, held while `fd` (and every copy of it)
// stays open. The table is one file, /run/sirupp-sandbox/uids (or /tmp/sirupp-sandbox-uids when
// /run cannot be written), in a folder of root's (mode 0700): byte i locked (an open file
// description lock, fcntl F_OFD_SETLK) is uid 2000000 + i held; its text is the next i to try, so
// a uid comes back only after the other 999999 were handed out. `problem` says why not, with
// uid -1 and fd -1.
struct HeldUid {
  int uid = -1;
  int fd = -1;  // not close-on-exec: bubblewrap's --sync-fd
  std::string problem;
};
HeldUid HoldFreeUid();

// Started as root, after the limits: become uid/gid `id` with no supplementary groups (which drops
// every capability), keeping the parent-death signal SIGKILL. Returns "" or what failed.
std::string DropTo(int id);

// One line naming the protections: "bubblewrap 0.8.0 namespaces (network, pid, ...), ...".
std::string Describe(const Probe& probe, const Limits& limits);

}  // namespace sirupp::sandbox
