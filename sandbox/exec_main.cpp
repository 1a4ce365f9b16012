// sirupp-sandbox-exec: the steps of the sandbox that bubblewrap does not take
// (sandbox/sandbox.hpp). Started by the sandbox's argv prefix, never by hand. Outside bubblewrap:
//
//   sirupp-sandbox-exec --supervise -- BWRAP ARGS...
//   sirupp-sandbox-exec --hold-uid --uid-at K [--give PATH]... -- BWRAP ARGS...     (as root)
//
// runs bubblewrap as its child and stays its parent, a subreaper: bubblewrap killed while it sets
// the sandbox up leaves its own child (the sandbox's init) waiting forever for a word that never
// comes, or running without its --die-with-parent; as a subreaper this process gets that orphan
// and kills it. It ends with bubblewrap's status once nothing it reaps is left; SIGTERM, SIGINT or
// SIGHUP (and the death of its own parent, as SIGTERM) go on to bubblewrap. --hold-uid first takes
// a uid no living sandbox holds (sandbox::HoldFreeUid), gives each PATH to it (chown), puts it in
// word K of BWRAP ARGS (0 = BWRAP; the inner --user's value) and gives bubblewrap the lock's
// descriptor as its --sync-fd: bubblewrap's init keeps it while the sandbox lives, and the program
// it runs does not get it. Inside bubblewrap:
//
//   sirupp-sandbox-exec [--cpu S] [--memory MB] [--processes N] [--file-size MB] [--sanitized]
//                       [--user UID] [--no-network] -- PROGRAM ARGS...
//
// in that order: the rlimits, (as root) become uid/gid UID, the socket filter, the memory limit,
// exec.
//
// Descriptors stay open across it. Exit 126 with one line when a step fails (nothing runs).

#include <dirent.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "sandbox/sandbox.hpp"

namespace {

int Fail(const std::string& what) {
  std::fprintf(stderr, "sirupp-sandbox-exec: %s\n", what.c_str());
  return 126;
}

bool ParseNumber(const char* text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text, &end);
  return end != text && *end == '\0' && *value >= 0;
}

// The processes whose parent is this one (what is left to reap), by /proc; none when /proc is
// another pid namespace's (its numbers would name other processes).
std::vector<pid_t> OwnChildren() {
  std::vector<pid_t> children;
  const std::string self = std::to_string(::getpid());
  std::ifstream own("/proc/self/stat");
  std::string own_pid;
  if (!(own >> own_pid) || own_pid != self) return children;
  DIR* proc = ::opendir("/proc");
  if (proc == nullptr) return children;
  while (const dirent* entry = ::readdir(proc)) {
    char* end = nullptr;
    const long pid = std::strtol(entry->d_name, &end, 10);
    if (pid <= 0 || *end != '\0') continue;
    std::ifstream stat(std::string("/proc/") + entry->d_name + "/stat");
    std::string text;
    if (!std::getline(stat, text)) continue;
    const size_t close = text.rfind(')');  // "pid (name) state ppid ..."
    if (close == std::string::npos || close + 4 > text.size()) continue;
    const size_t ppid_at = text.find(' ', close + 3);
    if (ppid_at == std::string::npos) continue;
    if (text.compare(ppid_at + 1, self.size() + 1, self + " ") == 0) {
      children.push_back(static_cast<pid_t>(pid));
    }
  }
  ::closedir(proc);
  return children;
}

// Runs `command` (bubblewrap) as a child and supervises it (see the top of this file). `held_fd`
// (or -1) is given to bubblewrap and closed here.
int Supervise(std::vector<std::string> command, int held_fd) {
  sigset_t watched;
  sigemptyset(&watched);
  for (const int sig : {SIGCHLD, SIGTERM, SIGINT, SIGHUP}) sigaddset(&watched, sig);
  sigset_t before;
  ::sigprocmask(SIG_BLOCK, &watched, &before);
  if (::prctl(PR_SET_CHILD_SUBREAPER, 1) != 0) {
    return Fail(std::string("prctl(PR_SET_CHILD_SUBREAPER): ") + std::strerror(errno));
  }
  // Its starter's end is a SIGTERM here. (proc::Child sets SIGKILL before the exec, so the time
  // before this line is covered too; a posix_spawn's child has none until here.)
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  std::vector<char*> raw;
  for (std::string& word : command) raw.push_back(word.data());
  raw.push_back(nullptr);
  const std::string cannot_run = "sirupp-sandbox-exec: cannot run " + command.front() + "\n";
  const pid_t self = ::getpid();
  const pid_t bwrap = ::fork();
  if (bwrap < 0) return Fail("cannot start " + command.front() + ": " + std::strerror(errno));
  if (bwrap == 0) {  // only async-signal-safe calls until exec
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != self) ::_exit(126);
    ::sigprocmask(SIG_SETMASK, &before, nullptr);
    ::execv(raw[0], raw.data());
    [[maybe_unused]] const ssize_t said = ::write(2, cannot_run.data(), cannot_run.size());
    ::_exit(126);
  }
  if (held_fd >= 0) ::close(held_fd);  // bubblewrap's init holds the uid now
  int status = 0;
  bool bwrap_ended = false;
  for (;;) {
    // Reap what ended; once bubblewrap has, what it left behind is killed.
    for (;;) {
      int reaped_status = 0;
      const pid_t reaped = ::waitpid(-1, &reaped_status, WNOHANG);
      if (reaped < 0 && errno == EINTR) continue;
      if (reaped <= 0) break;
      if (reaped == bwrap) {
        status = reaped_status;
        bwrap_ended = true;
      }
    }
    if (bwrap_ended) {
      const std::vector<pid_t> left = OwnChildren();
      if (left.empty()) break;
      for (const pid_t pid : left) ::kill(pid, SIGKILL);
    }
    siginfo_t info{};
    const int sig = ::sigwaitinfo(&watched, &info);
    if (sig < 0) continue;  // EINTR
    if (sig != SIGCHLD && !bwrap_ended) ::kill(bwrap, sig);
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) {  // ends the same way
    ::prctl(PR_SET_PDEATHSIG, 0);
    ::signal(WTERMSIG(status), SIG_DFL);
    ::sigprocmask(SIG_UNBLOCK, &watched, nullptr);
    ::raise(WTERMSIG(status));
    return 128 + WTERMSIG(status);
  }
  return 126;
}

// --hold-uid: outside bubblewrap, as root (see above).
int HoldUidAndStart(int argc, char** argv) {
  long uid_at = -1;
  std::vector<std::string> give;
  int i = 2;
  for (; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--") break;
    if (i + 1 >= argc)
      return Fail("'" + flag + "' needs a value (usage: see sandbox/exec_main.cpp)");
    const std::string value = argv[++i];
    if (flag == "--uid-at") {
      char* end = nullptr;
      uid_at = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || uid_at < 1) {
        return Fail("--uid-at '" + value + "': a word's position (1 or more) after --");
      }
    } else if (flag == "--give") {
      give.push_back(value);
    } else {
      return Fail("--hold-uid: unknown option '" + flag + "' (allowed: --uid-at K, --give PATH)");
    }
  }
  std::vector<std::string> command(argv + std::min(i + 1, argc), argv + argc);
  if (command.empty()) return Fail("--hold-uid: no bubblewrap command after --");
  if (uid_at < 1 || uid_at >= static_cast<long>(command.size()) ||
      command[static_cast<size_t>(uid_at) - 1] != "--user") {
    return Fail("--hold-uid: --uid-at must name the word after the inner --user (got " +
                std::to_string(uid_at) + " of " + std::to_string(command.size()) + " words)");
  }
  const sirupp::sandbox::HeldUid held = sirupp::sandbox::HoldFreeUid();
  if (held.fd < 0) return Fail("cannot hold a uid for the sandbox: " + held.problem);
  for (const std::string& path : give) {
    if (::chown(path.c_str(), static_cast<uid_t>(held.uid), static_cast<gid_t>(held.uid)) != 0) {
      return Fail("cannot give " + path + " to uid " + std::to_string(held.uid) + ": " +
                  std::strerror(errno));
    }
  }
  command[static_cast<size_t>(uid_at)] = std::to_string(held.uid);
  command.insert(command.begin() + 1, {"--sync-fd", std::to_string(held.fd)});
  return Supervise(command, held.fd);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "--hold-uid") return HoldUidAndStart(argc, argv);
  if (argc > 1 && std::string(argv[1]) == "--supervise") {
    if (argc < 4 || std::string(argv[2]) != "--") {
      return Fail("--supervise: usage: --supervise -- BWRAP ARGS...");
    }
    return Supervise(std::vector<std::string>(argv + 3, argv + argc), -1);
  }
  sirupp::sandbox::Limits limits;
  bool apply_limits = false, sanitized = false, no_network = false;
  int user = -1;
  int i = 1;
  for (; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--") break;
    if (flag == "--sanitized") {
      sanitized = true;
      continue;
    }
    if (flag == "--no-network") {
      no_network = true;
      continue;
    }
    double value = 0;
    if (i + 1 >= argc || !ParseNumber(argv[i + 1], &value)) {
      return Fail("'" + flag + "' needs a number (usage: see sandbox/exec_main.cpp)");
    }
    ++i;
    if (flag == "--user") {
      user = static_cast<int>(value);
    } else if (flag == "--cpu") {
      limits.cpu_s = value;
      apply_limits = true;
    } else if (flag == "--memory") {
      limits.memory_mb = static_cast<uint64_t>(value);
      apply_limits = true;
    } else if (flag == "--processes") {
      limits.processes = static_cast<int>(value);
      apply_limits = true;
    } else if (flag == "--file-size") {
      limits.file_size_mb = static_cast<uint64_t>(value);
      apply_limits = true;
    } else {
      return Fail("unknown option '" + flag + "'");
    }
  }
  if (i + 1 >= argc) return Fail("no command after --");
  if (apply_limits) {
    if (const std::string problem = sirupp::sandbox::ApplyLimits(limits, sanitized);
        !problem.empty()) {
      return Fail(problem);
    }
  }
  if (user >= 0) {
    if (const std::string problem = sirupp::sandbox::DropTo(user); !problem.empty()) {
      return Fail(problem);
    }
  }
  if (no_network) {
    if (const std::string problem = sirupp::sandbox::ForbidNetworkSockets(); !problem.empty()) {
      return Fail(problem);
    }
  }
  if (apply_limits) {
    if (const std::string problem = sirupp::sandbox::ApplyMemoryLimit(limits, sanitized);
        !problem.empty()) {
      return Fail(problem);
    }
  }
  ::execv(argv[i + 1], argv + i + 1);
  return Fail(std::string("cannot run ") + argv[i + 1] + ": " + std::strerror(errno));
}
