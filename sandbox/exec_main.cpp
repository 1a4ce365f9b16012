// sirupp-sandbox-exec: the steps of the sandbox that bubblewrap does not take
// (sandbox/sandbox.hpp). Started by the sandbox's argv prefix, never by hand. Outside bubblewrap,
// started as root:
//
//   sirupp-sandbox-exec --hold-uid --uid-at K [--give PATH]... -- BWRAP ARGS...
//
// takes a uid no living sandbox holds (sandbox::HoldFreeUid), gives each PATH to it (chown),
// puts it in word K of BWRAP ARGS (0 = BWRAP; the inner --user's value) and execs bubblewrap with
// the lock's descriptor as its --sync-fd: bubblewrap's init keeps it while the sandbox lives, and
// the program it runs does not get it. Inside bubblewrap:
//
//   sirupp-sandbox-exec [--cpu S] [--memory MB] [--processes N] [--file-size MB] [--sanitized]
//                       [--user UID] [--no-network] -- PROGRAM ARGS...
//
// in that order: the rlimits, (as root) become uid/gid UID, the socket filter, the memory limit,
// exec.
//
// Descriptors stay open across it. Exit 126 with one line when a step fails (nothing runs).

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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
  std::vector<char*> raw;
  for (std::string& word : command) raw.push_back(word.data());
  raw.push_back(nullptr);
  ::execv(raw[0], raw.data());
  return Fail("cannot run " + command.front() + ": " + std::strerror(errno));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "--hold-uid") return HoldUidAndStart(argc, argv);
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
