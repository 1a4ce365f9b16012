#include "sandbox/sandbox.hpp"

#include <fcntl.h>
#include <grp.h>
#include <linux/audit.h>
#include <linux/capability.h>
#include <linux/filter.h>
#include <linux/seccomp.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace sirupp::sandbox {
namespace fs = std::filesystem;

#if defined(__SANITIZE_ADDRESS__)
const bool Policy::kSanitizedBuild = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
const bool Policy::kSanitizedBuild = true;
#else
const bool Policy::kSanitizedBuild = false;
#endif
#else
const bool Policy::kSanitizedBuild = false;
#endif

namespace {

constexpr int kFirstUid = 2000000;  // as root: sandboxes run as uids from here
constexpr int kUids = 1000000;
constexpr const char* kHelperName = "sirupp-sandbox-exec";
// As root: the table of held uids, in a folder of root's alone (the first that can be made).
constexpr const char* kUidLockFolders[] = {"/run/sirupp-sandbox", "/tmp/sirupp-sandbox-uids"};
constexpr const char* kUidLockName = "uids";
// The inner helper's --user until the outer step puts the uid it holds there.
constexpr const char* kUidWord = "UID";

#if defined(__x86_64__)
constexpr uint32_t kAuditArch = AUDIT_ARCH_X86_64;
constexpr bool kFilterSupported = true;
#elif defined(__aarch64__)
constexpr uint32_t kAuditArch = AUDIT_ARCH_AARCH64;
constexpr bool kFilterSupported = true;
#else
constexpr uint32_t kAuditArch = 0;
constexpr bool kFilterSupported = false;
#endif

std::string FindOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr && *path != '\0' ? path : "/usr/bin:/bin";
  dirs += ":/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::string candidate = dirs.substr(start, end - start) + "/" + name;
    if (end > start && ::access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return "";
}

// sirupp-sandbox-exec: in SIRUPP_BIN_DIR (tests, sirupp grade), else beside the running program.
std::string FindHelper() {
  std::vector<fs::path> dirs;
  if (const char* dir = std::getenv("SIRUPP_BIN_DIR"); dir != nullptr && *dir != '\0') {
    dirs.emplace_back(dir);
  }
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (!error) dirs.push_back(self.parent_path());
  for (const fs::path& dir : dirs) {
    const fs::path candidate = fs::absolute(dir / kHelperName, error);
    if (!error && ::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return "";
}

std::string Absolute(const std::string& path) {
  std::error_code error;
  const fs::path canonical = fs::weakly_canonical(fs::absolute(path), error);
  return error ? fs::absolute(path).lexically_normal().string() : canonical.string();
}

// Started as root the code runs as a uid of its own, which must be able to read `path` (bwrap
// mounts it as root, so the folders above it do not matter): "" or the reason.
std::string OthersCannotRead(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return "";  // bwrap names a missing path itself
  const mode_t needed = S_ISDIR(info.st_mode) ? (S_IROTH | S_IXOTH) : S_IROTH;
  if ((info.st_mode & needed) != needed) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%03o", info.st_mode & 0777);
    return path + " (mode " + mode + ") is not readable by others";
  }
  return "";
}

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.15g", value);
  return text;
}

// The bubblewrap part of the command; as root the inner helper's uid is kUidWord, which the outer
// step (sirupp-sandbox-exec --hold-uid) replaces with the uid it holds.
std::vector<std::string> BuildArgv(const Probe& probe, const Policy& policy,
                                   const std::vector<std::string>& argv) {
  std::vector<std::string> out = {probe.bwrap};
  if (probe.as_root) {
    // Privileged bubblewrap: no user namespace (root's would not count processes); the helper
    // inside becomes `uid` after the limits, which takes every capability away.
    out.insert(out.end(), {"--unshare-ipc", "--unshare-pid", "--unshare-net", "--unshare-uts",
                           "--unshare-cgroup-try", "--cap-add", "CAP_SETUID", "--cap-add",
                           "CAP_SETGID", "--cap-add", "CAP_SETPCAP"});
  } else {
    out.emplace_back("--unshare-all");
  }
  out.insert(out.end(), {"--die-with-parent", "--new-session", "--ro-bind", "/usr", "/usr"});
  for (const char* link : {"lib", "lib64", "bin", "sbin"}) {
    const fs::path root_link = fs::path("/") / link;
    std::error_code error;
    if (fs::is_symlink(root_link, error)) {
      out.insert(out.end(),
                 {"--symlink", fs::read_symlink(root_link, error).string(), root_link.string()});
    } else if (fs::is_directory(root_link, error)) {
      out.insert(out.end(), {"--ro-bind", root_link.string(), root_link.string()});
    }
  }
  out.insert(out.end(), {"--perms",
                         "0755",
                         "--dir",
                         "/etc",
                         "--ro-bind-try",
                         "/etc/ld.so.cache",
                         "/etc/ld.so.cache",
                         "--ro-bind-try",
                         "/etc/alternatives",
                         "/etc/alternatives",
                         "--proc",
                         "/proc",
                         "--dev",
                         "/dev",
                         "--perms",
                         "1777",
                         "--size",
                         std::to_string(policy.limits.tmp_mb << 20),
                         "--tmpfs",
                         "/tmp"});
  std::vector<std::string> read_only = policy.read_only;
  read_only.push_back(probe.helper);
  if (!argv.empty() && !argv.front().empty() && argv.front()[0] == '/') {
    read_only.push_back(argv.front());
  }
  // The folders above each path, made searchable (bwrap makes them 0700, its own when
  // privileged), then the paths; what /usr holds is there already.
  std::vector<std::string> made = {"/", "/tmp"};
  auto bind = [&out, &made](const std::string& how, const std::string& path) {
    const std::string absolute = Absolute(path);
    if (absolute.rfind("/usr/", 0) == 0 && how != "--bind") return;
    std::vector<std::string> above;
    for (fs::path parent = fs::path(absolute).parent_path(); parent.has_relative_path();
         parent = parent.parent_path()) {
      above.push_back(parent.string());
    }
    std::reverse(above.begin(), above.end());  // from the top down
    for (const std::string& folder : above) {
      if (std::find(made.begin(), made.end(), folder) != made.end()) continue;
      made.push_back(folder);
      out.insert(out.end(), {"--perms", "0755", "--dir", folder});
    }
    out.insert(out.end(), {how, absolute, absolute});
  };
  // A missing path is simply not there inside: the program names it in its own words.
  for (const std::string& path : read_only) bind("--ro-bind-try", path);
  for (const std::string& path : policy.read_write) bind("--bind", path);
  const std::string chdir = policy.chdir.empty() ? "/" : Absolute(policy.chdir);
  if (std::find(made.begin(), made.end(), chdir) == made.end()) {
    out.insert(out.end(), {"--perms", "0755", "--dir", chdir});  // may be no path's folder
  }
  out.insert(out.end(),
             {"--chdir", chdir, "--clearenv", "--setenv", "PATH", "/usr/bin:/bin", "--setenv",
              "HOME", "/tmp", "--setenv", "LANG", "C", "--setenv", "TMPDIR", "/tmp"});
  for (const char* keep : {"ASAN_OPTIONS", "UBSAN_OPTIONS", "LSAN_OPTIONS"}) {
    if (const char* value = std::getenv(keep); value != nullptr) {
      out.insert(out.end(), {"--setenv", keep, value});
    }
  }
  const Limits& limits = policy.limits;
  out.insert(out.end(), {"--", probe.helper});
  if (probe.as_root) out.insert(out.end(), {"--user", kUidWord});
  out.insert(
      out.end(),
      {"--cpu", Number(limits.cpu_s), "--memory", std::to_string(limits.memory_mb), "--processes",
       std::to_string(limits.processes), "--file-size", std::to_string(limits.file_size_mb)});
  if (policy.sanitized_target) out.emplace_back("--sanitized");
  out.insert(out.end(), {"--no-network", "--"});
  out.insert(out.end(), argv.begin(), argv.end());
  // Outside, bubblewrap runs under sirupp-sandbox-exec, which stays its parent and kills what a
  // bubblewrap killed during its set-up leaves behind. As root it first takes a uid no living
  // sandbox has, gives it the read-write paths and holds it for as long as bubblewrap lives.
  if (!probe.as_root) {
    out.insert(out.begin(), {probe.helper, "--supervise", "--"});
    return out;
  }
  const auto word = std::find(out.begin(), out.end(), kUidWord);
  std::vector<std::string> outer = {probe.helper, "--hold-uid", "--uid-at",
                                    std::to_string(word - out.begin())};
  for (const std::string& path : policy.read_write) {
    outer.insert(outer.end(), {"--give", Absolute(path)});
  }
  outer.emplace_back("--");
  outer.insert(outer.end(), out.begin(), out.end());
  return outer;
}

// Runs `argv` with its output into a pipe; the exit status and the output (for the probe). The
// child dies with this process (SIGKILL): a grading job cancelled while it probes (scancel's
// SIGTERM reaching this process first) must leave no sandbox behind, which process tracking
// by descent (Slurm's proctrack/linuxproc) would no longer find once its parent is gone.
int RunCapturing(const std::vector<std::string>& argv, std::string* output) {
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0) return -1;
  std::vector<char*> raw;
  for (const std::string& word : argv) raw.push_back(const_cast<char*>(word.c_str()));
  raw.push_back(nullptr);
  const std::string cannot_start = "cannot start " + argv[0];
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {  // only async-signal-safe calls until exec
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);  // the parent died before the line above
    ::dup2(pipe_fds[1], 1);
    ::dup2(pipe_fds[1], 2);
    ::execve(raw[0], raw.data(), environ);
    [[maybe_unused]] const ssize_t said = ::write(2, cannot_start.data(), cannot_start.size());
    ::_exit(127);
  }
  const int fork_error = errno;
  ::close(pipe_fds[1]);
  if (pid < 0) {
    ::close(pipe_fds[0]);
    *output = cannot_start + ": " + std::strerror(fork_error);
    return -1;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  char buffer[512];
  for (;;) {
    pollfd wait_for{pipe_fds[0], POLLIN, 0};
    if (::poll(&wait_for, 1, 100) > 0) {
      const ssize_t got = ::read(pipe_fds[0], buffer, sizeof buffer);
      if (got > 0 && output->size() < 4096) output->append(buffer, static_cast<size_t>(got));
      if (got == 0) break;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      output->append("(no answer within 20 s)");
      break;
    }
  }
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

Probe MakeProbe() {
  Probe probe;
  probe.as_root = ::geteuid() == 0;
  probe.seccomp = kFilterSupported;
  // SIRUPP_BWRAP names another bubblewrap (the tests give one that fails, as a machine without
  // user namespaces would).
  const char* bwrap = std::getenv("SIRUPP_BWRAP");
  probe.bwrap = bwrap != nullptr && *bwrap != '\0'
                    ? (::access(bwrap, X_OK) == 0 ? std::string(bwrap) : std::string())
                    : FindOnPath("bwrap");
  probe.helper = FindHelper();
  if (probe.bwrap.empty()) {
    probe.problem =
        "bubblewrap (bwrap) is not installed; the administrator installs it (apt-get install "
        "bubblewrap)";
    return probe;
  }
  if (probe.helper.empty()) {
    probe.problem = std::string(kHelperName) +
                    " is not beside this program nor in SIRUPP_BIN_DIR (an incomplete build or "
                    "install)";
    return probe;
  }
  Policy policy;
  policy.sanitized_target = false;
  std::string output;
  // Tried up to three times: the verdict holds for the process's life, and on a loaded machine a
  // single try has failed once in a while where the next one works (a machine that cannot make
  // the sandbox fails all three the same way).
  int status = 0;
  for (int attempt = 0; attempt < 3; ++attempt) {
    if (attempt > 0) ::usleep(attempt == 1 ? 200000 : 1000000);
    output.clear();
    status = RunCapturing(BuildArgv(probe, policy, {"/usr/bin/true"}), &output);
    if (status == 0) break;
  }
  while (!output.empty() && (output.back() == '\n' || output.back() == ' ')) output.pop_back();
  if (status != 0) {
    probe.problem = "bubblewrap cannot make its sandbox here" +
                    (output.empty() ? std::string() : " (" + output + ")") +
                    ": it needs unprivileged user namespaces (sysctl user.max_user_namespaces > "
                    "0, and on Debian kernel.unprivileged_userns_clone=1), which the "
                    "administrator enables";
    return probe;
  }
  probe.usable = true;
  return probe;
}

}  // namespace

const Probe& ProbeMachine() {
  static const Probe probe = MakeProbe();
  return probe;
}

std::vector<std::string> Wrap(const Policy& policy, const std::vector<std::string>& argv) {
  const Probe& probe = ProbeMachine();
  if (!probe.usable) {
    throw std::runtime_error("the sandbox cannot be had on this machine: " + probe.problem);
  }
  if (argv.empty()) throw std::runtime_error("the sandbox got no command");
  if (probe.as_root) {
    std::vector<std::string> paths = policy.read_only;
    paths.push_back(argv.front());
    for (const std::string& path : paths) {
      const std::string problem = OthersCannotRead(Absolute(path));
      if (!problem.empty()) {
        throw std::runtime_error(
            "started as root, the sandbox runs the code as a user of its "
            "own, who cannot read " +
            problem);
      }
    }
    // The outer step gives them to the sandbox's uid; a missing one is named here already.
    for (const std::string& path : policy.read_write) {
      struct stat info {};
      if (::stat(Absolute(path).c_str(), &info) != 0) {
        throw std::runtime_error("the sandbox cannot give " + Absolute(path) +
                                 " to its user: " + std::strerror(errno));
      }
    }
  }
  return BuildArgv(probe, policy, argv);
}

HeldUid HoldFreeUid() {
  HeldUid held;
  std::string folder;
  for (const char* candidate : kUidLockFolders) {
    if (::mkdir(candidate, 0700) != 0 && errno != EEXIST) {
      held.problem += std::string(held.problem.empty() ? "" : "; ") + "cannot make " + candidate +
                      ": " + std::strerror(errno);
      continue;  // /run may be read-only or missing: the next one
    }
    struct stat info {};
    if (::lstat(candidate, &info) != 0 || !S_ISDIR(info.st_mode) || info.st_uid != 0 ||
        (info.st_mode & 077) != 0) {
      // Someone else's folder would let them take or hold uids: refuse it.
      held.problem = std::string(candidate) +
                     " must be a folder of root's that no one else may open (mode 0700); "
                     "remove it and it is made again";
      return held;
    }
    folder = candidate;
    held.problem.clear();  // an earlier candidate's, if any
    break;
  }
  if (folder.empty()) return held;
  const std::string file = folder + "/" + kUidLockName;
  // Without O_CLOEXEC: the descriptor is bubblewrap's --sync-fd.
  held.fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW, 0600);
  if (held.fd < 0) {
    held.problem = "cannot open " + file + ": " + std::strerror(errno);
    return held;
  }
  auto lock = [&held](short type, off_t at, int command) {
    struct flock range {};
    range.l_type = type;
    range.l_whence = SEEK_SET;
    range.l_start = at;
    range.l_len = 1;
    int result = 0;
    do {
      result = ::fcntl(held.fd, command, &range);
    } while (result != 0 && errno == EINTR);
    return result == 0;
  };
  auto fail = [&held, &file](const std::string& what) {
    held.problem = what + " (" + file + "): " + std::strerror(errno);
    ::close(held.fd);
    held.fd = -1;
    return held;
  };
  // Byte kUids locked: a sandbox is choosing (and reads and writes the next index to try).
  if (!lock(F_WRLCK, kUids, F_OFD_SETLKW)) return fail("cannot lock the uid table");
  char text[24] = {};
  const ssize_t got = ::pread(held.fd, text, sizeof text - 1, 0);
  long next = got > 0 ? std::strtol(text, nullptr, 10) : 0;
  if (next < 0 || next >= kUids) next = 0;
  for (long tried = 0; tried < kUids; ++tried) {
    const long index = (next + tried) % kUids;
    if (lock(F_WRLCK, index, F_OFD_SETLK)) {
      const std::string after = std::to_string((index + 1) % kUids) + "\n";
      if (::ftruncate(held.fd, 0) != 0 ||
          ::pwrite(held.fd, after.data(), after.size(), 0) != static_cast<ssize_t>(after.size())) {
        return fail("cannot write the uid table");
      }
      lock(F_UNLCK, kUids, F_OFD_SETLK);
      held.uid = kFirstUid + static_cast<int>(index);
      return held;
    }
    if (errno != EAGAIN && errno != EACCES) return fail("cannot lock a uid");
  }
  errno = EAGAIN;
  return fail("all " + std::to_string(kUids) + " sandbox uids are held by living sandboxes");
}

int UnwrapStatus(int status) {
  if (WIFEXITED(status) && WEXITSTATUS(status) > 128 && WEXITSTATUS(status) < 128 + 65) {
    return WEXITSTATUS(status) - 128;  // a wait status "killed by signal N"
  }
  return status;
}

std::string ApplyLimits(const Limits& limits, bool sanitized_target) {
  auto set = [](int resource, rlim_t soft, rlim_t hard, const char* name) -> std::string {
    const rlimit value{soft, hard};
    if (::setrlimit(resource, &value) != 0) {
      return std::string("setrlimit(") + name + "): " + std::strerror(errno);
    }
    return "";
  };
  const auto cpu = static_cast<rlim_t>(std::ceil(std::max(limits.cpu_s, 1.0)));
  const rlim_t mb = 1 << 20;
  std::string problem = set(RLIMIT_CPU, cpu, cpu + 1, "RLIMIT_CPU");
  if (problem.empty()) problem = set(RLIMIT_CORE, 0, 0, "RLIMIT_CORE");
  if (problem.empty()) {
    const auto processes = static_cast<rlim_t>(std::max(limits.processes, 1));
    problem = set(RLIMIT_NPROC, processes, processes, "RLIMIT_NPROC");
  }
  if (problem.empty()) {
    problem = set(RLIMIT_FSIZE, limits.file_size_mb * mb, limits.file_size_mb * mb, "RLIMIT_FSIZE");
  }
  if (!problem.empty()) return problem;
  if (!sanitized_target) return "";  // RLIMIT_AS: ApplyMemoryLimit, last before exec
  // AddressSanitizer's shadow memory is terabytes of address space: its own resident-memory
  // limit stands in for RLIMIT_AS.
  const char* old = std::getenv("ASAN_OPTIONS");
  const std::string options = (old != nullptr && *old != '\0' ? std::string(old) + ":" : "") +
                              "hard_rss_limit_mb=" + std::to_string(limits.memory_mb);
  if (::setenv("ASAN_OPTIONS", options.c_str(), 1) != 0) {
    return std::string("setenv(ASAN_OPTIONS): ") + std::strerror(errno);
  }
  return "";
}

std::string ApplyMemoryLimit(const Limits& limits, bool sanitized_target) {
  if (sanitized_target) return "";  // ApplyLimits set ASan's limit
  const rlim_t bytes = static_cast<rlim_t>(limits.memory_mb) << 20;
  const rlimit value{bytes, bytes};
  if (::setrlimit(RLIMIT_AS, &value) != 0) {
    return std::string("setrlimit(RLIMIT_AS): ") + std::strerror(errno);
  }
  return "";
}

std::string ForbidNetworkSockets() {
  if (!kFilterSupported) return "";  // the network namespace alone then
  constexpr uint32_t kRefuse = SECCOMP_RET_ERRNO | (EACCES & SECCOMP_RET_DATA);
  sock_filter filter[] = {
    BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, arch)),
    BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, kAuditArch, 1, 0),
    BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_KILL_PROCESS),  // another ABI's system calls
    BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, nr)),
#if defined(__x86_64__)
    BPF_JUMP(BPF_JMP | BPF_JGE | BPF_K, 0x40000000U, 0, 1),  // the x32 ABI's numbers
    BPF_STMT(BPF_RET | BPF_K, kRefuse),
#endif
    // io_uring can open sockets without socket().
    BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, __NR_io_uring_setup, 0, 1),
    BPF_STMT(BPF_RET | BPF_K, kRefuse),
    BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, __NR_socket, 0, 3),
    // The domain (an int: the low half of args[0] on these little-endian machines).
    BPF_STMT(BPF_LD | BPF_W | BPF_ABS, offsetof(seccomp_data, args[0])),
    BPF_JUMP(BPF_JMP | BPF_JEQ | BPF_K, AF_UNIX, 1, 0),
    BPF_STMT(BPF_RET | BPF_K, kRefuse),
    BPF_STMT(BPF_RET | BPF_K, SECCOMP_RET_ALLOW),
  };
  const sock_fprog program{static_cast<unsigned short>(sizeof filter / sizeof filter[0]), filter};
  if (::prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) {
    return std::string("prctl(PR_SET_NO_NEW_PRIVS): ") + std::strerror(errno);
  }
  if (::prctl(PR_SET_SECCOMP, SECCOMP_MODE_FILTER, &program, 0, 0) != 0) {
    return std::string("the seccomp socket filter: ") + std::strerror(errno);
  }
  return "";
}

std::string DropTo(int id) {
  const auto uid = static_cast<uid_t>(id);
  const auto gid = static_cast<gid_t>(id);
  // No capability can come back: not through the bounding set, the inheritable set or exec.
  for (int cap = 0; cap <= 63; ++cap) {
    if (::prctl(PR_CAPBSET_DROP, cap, 0, 0, 0) != 0 && errno != EINVAL) {
      return std::string("cannot drop the capability bounding set: ") + std::strerror(errno);
    }
  }
  if (::prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) {
    return std::string("prctl(PR_SET_NO_NEW_PRIVS): ") + std::strerror(errno);
  }
  if (::setgroups(0, nullptr) != 0 || ::setgid(gid) != 0 || ::setuid(uid) != 0) {
    return "cannot become uid " + std::to_string(id) + ": " + std::strerror(errno);
  }
  __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
  __user_cap_data_struct none[2] = {};
  if (::syscall(SYS_capset, &header, none) != 0) {
    return std::string("cannot clear the capabilities: ") + std::strerror(errno);
  }
  if (::setuid(0) == 0)
    return "could become root again after dropping to uid " + std::to_string(id);
  // Changing the user cleared the parent-death signal; the sandbox ends with its parent.
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  return "";
}

std::string Describe(const Probe& probe, const Limits& limits) {
  if (!probe.usable) return "no sandbox: " + probe.problem;
  std::string text =
      std::string("sandbox: bubblewrap (own ") +
      (probe.as_root ? "network, pid, ipc namespaces" : "user, network, pid, ipc namespaces") +
      "; /usr and the named paths read-only, a private /tmp), limits " + Number(limits.cpu_s) +
      " s CPU, " + std::to_string(limits.memory_mb) + " MB memory, " +
      std::to_string(limits.processes) + " processes, " + std::to_string(limits.file_size_mb) +
      " MB per file";
  if (probe.seccomp) text += ", sockets other than AF_UNIX refused (seccomp)";
  if (probe.as_root) text += ", as a uid of its own";
  return text;
}

}  // namespace sirupp::sandbox
